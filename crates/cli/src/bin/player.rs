//! The `player` binary (work in progress: its jobs arrive with the issues that build them).

fn main() -> anyhow::Result<()> {
    anyhow::bail!("`player` is not built yet")
}
