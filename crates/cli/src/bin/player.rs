//! The `player` binary. For now it only checks configurations: `player --check FILE.cfg` parses
//! the cfg and its worldfile and reports every driver and device it would create (serving
//! arrives with a later issue).

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Parser;
use worldfile::{CfgFile, LoadOptions, check};

/// Player 3.0.2-compatible robot server.
#[derive(Parser, Debug)]
#[command(name = "player", version)]
struct Args {
    /// Parse the cfg and its worldfile, report the drivers, devices, ports and model bindings,
    /// and exit (status 1 if the server would refuse the configuration).
    #[arg(long)]
    check: bool,
    /// Print the check report as JSON.
    #[arg(long, requires = "check")]
    json: bool,
    /// Default port for addresses without one.
    #[arg(short = 'p', long = "port", default_value_t = 6665)]
    port: u16,
    /// Do not print warnings.
    #[arg(short, long)]
    quiet: bool,
    /// The configuration file.
    cfgfile: PathBuf,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    if !args.check {
        bail!("serving is not built yet; use `player --check FILE.cfg`");
    }
    let opts = LoadOptions::from_env();
    let cfg = CfgFile::load(&args.cfgfile, &opts).map_err(|e| anyhow::anyhow!("{e}"))?;
    let (report, _world) = check::check(&cfg, args.port, &opts);
    if !args.quiet {
        for w in &report.warnings {
            eprintln!("{w}");
        }
    }
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&report).context("serialising the report")?
        );
    } else {
        println!("{report}");
    }
    if !report.problems.is_empty() {
        bail!(
            "{} problem(s): the server would refuse this configuration",
            report.problems.len()
        );
    }
    Ok(())
}
