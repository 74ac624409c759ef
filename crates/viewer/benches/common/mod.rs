//! What the viewer's benchmarks share: their few command-line options.

/// The value after `flag` in `args`, parsed (`None` when the flag is absent or its value does
/// not parse).
pub fn value<T: std::str::FromStr>(args: &[String], flag: &str) -> Option<T> {
    let i = args.iter().position(|a| a == flag)?;
    args.get(i + 1)?.parse().ok()
}
