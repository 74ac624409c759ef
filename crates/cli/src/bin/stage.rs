//! The `stage` binary (work in progress: its jobs arrive with the issues that build them).

fn main() -> anyhow::Result<()> {
    anyhow::bail!("`stage` is not built yet")
}
