//! The `stage` binary. For now it only reads worldfiles: `stage --dump FILE.world` prints the
//! resolved world as JSON (the simulator itself arrives with a later issue).

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Parser;
use worldfile::{LoadOptions, WorldSpec};

/// Stage 4.1.1-compatible simulator.
#[derive(Parser, Debug)]
#[command(name = "stage", version)]
struct Args {
    /// Print the resolved world (models, properties, blocks) as JSON and exit.
    #[arg(long)]
    dump: bool,
    /// Do not print warnings.
    #[arg(short, long)]
    quiet: bool,
    /// The worldfile.
    worldfile: PathBuf,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if !args.dump {
        bail!("running the simulation is not built yet; use `stage --dump FILE.world`");
    }
    let world = WorldSpec::load(&args.worldfile, &LoadOptions::from_env())
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    if !args.quiet {
        for w in &world.warnings {
            eprintln!("{w}");
        }
    }
    let json = serde_json::to_string_pretty(&world).context("serialising the world")?;
    println!("{json}");
    Ok(())
}
