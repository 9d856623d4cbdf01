//! Process CPU time (user + system, every thread), for CPU-seconds-per-iteration
//! figures that do not depend on how busy the shared machine is.

use std::time::Duration;

/// User plus system CPU time the whole process has used so far (all threads), from
/// `getrusage(RUSAGE_SELF)`. Microsecond resolution on Linux.
#[cfg(unix)]
pub fn process_cpu_time() -> Duration {
    // SAFETY: `rusage` is plain old data, so all-zero bytes are a valid value, and
    // getrusage only writes into the struct we pass it.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    let rc = unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut ru) };
    if rc != 0 {
        return Duration::ZERO;
    }
    let tv = |t: libc::timeval| {
        Duration::from_secs(t.tv_sec.max(0) as u64) + Duration::from_micros(t.tv_usec.max(0) as u64)
    };
    tv(ru.ru_utime) + tv(ru.ru_stime)
}

/// Not measured on this platform: always zero.
#[cfg(not(unix))]
pub fn process_cpu_time() -> Duration {
    Duration::ZERO
}

/// Wall-clock and CPU time of a stretch of work.
#[derive(Clone, Copy, Debug)]
pub struct Stopwatch {
    wall: std::time::Instant,
    cpu: Duration,
}

impl Stopwatch {
    pub fn start() -> Self {
        Stopwatch {
            wall: std::time::Instant::now(),
            cpu: process_cpu_time(),
        }
    }

    /// (wall, cpu) since `start`.
    pub fn elapsed(&self) -> (Duration, Duration) {
        (
            self.wall.elapsed(),
            process_cpu_time().saturating_sub(self.cpu),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_time_grows_with_work() {
        let sw = Stopwatch::start();
        // Spin for a while so the process uses measurable CPU time.
        let mut x = 0u64;
        while sw.elapsed().0 < Duration::from_millis(50) {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        std::hint::black_box(x);
        let (_, cpu) = sw.elapsed();
        if cfg!(unix) {
            assert!(cpu >= Duration::from_millis(20), "{cpu:?}");
        }
    }
}
