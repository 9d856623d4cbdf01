//! AFL target: see caustic_fuzz::run. `fuzz_nohook`: a panic that caustic catches
//! and turns into an error (around third-party decoders) is no finding; any other
//! panic still aborts the run and is saved as a crash.
fn main() {
    afl::fuzz_nohook!(|data: &[u8]| {
        let _ = caustic_fuzz::run("vdb", data);
    });
}
