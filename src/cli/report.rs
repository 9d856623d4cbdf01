//! How a failed command reports its error: one line, each cause once.

/// The error and its causes joined with ": ". A cause whose text the line already
/// holds is left out: many errors repeat their source in their own message (`I/O
/// error on x.exr: No such file`), and printing the chain again would say it twice.
pub fn error_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if text.is_empty() || line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("I/O error on a.exr: {0}")]
    struct Repeats(#[source] std::io::Error);

    #[test]
    fn a_cause_is_printed_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
        let e = anyhow::Error::new(Repeats(io));
        assert_eq!(error_line(&e), "I/O error on a.exr: No such file");
        let e = anyhow::anyhow!("the root cause").context("reading the scene");
        assert_eq!(error_line(&e), "reading the scene: the root cause");
    }
}
