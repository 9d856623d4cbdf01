//! Runs saved inputs through a target without AFL, to reproduce a finding under a
//! debugger or with a backtrace: `repro TARGET FILE...`.
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some((target, files)) = args.split_first() else {
        eprintln!(
            "usage: repro TARGET FILE...  (targets: {:?})",
            caustic_fuzz::TARGETS
        );
        std::process::exit(2);
    };
    for file in files {
        let data = std::fs::read(file).unwrap_or_else(|e| panic!("{file}: {e}"));
        eprintln!("{file}: {} bytes", data.len());
        match caustic_fuzz::run(target, &data) {
            Some(outcome) => eprintln!("  {outcome}"),
            None => {
                eprintln!(
                    "unknown target {target}; targets: {:?}",
                    caustic_fuzz::TARGETS
                );
                std::process::exit(2);
            }
        }
    }
    eprintln!("no crash");
}
