//! The `playerv` binary (work in progress: its jobs arrive with the issues that build them).

fn main() -> anyhow::Result<()> {
    anyhow::bail!("`playerv` is not built yet")
}
