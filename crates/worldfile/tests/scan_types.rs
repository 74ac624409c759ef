use std::path::Path;
use worldfile::{Dialect, LoadOptions};
#[test]
#[ignore]
fn scan() {
    let root = Path::new("/work/shared/stage-worlds");
    let mut opts = LoadOptions::default();
    opts.stage_path.push(root.to_path_buf());
    for dir in ["", "wifi", "benchmark"] {
        for e in std::fs::read_dir(root.join(dir)).unwrap() {
            let p = e.unwrap().path();
            let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
            if ext != "world" {
                continue;
            }
            let t = std::time::Instant::now();
            match worldfile::world::WorldSpec::load(&p, &opts) {
                Ok(w) => {
                    println!(
                        "OK {} models={} warnings={} {:?}",
                        p.display(),
                        w.models.len(),
                        w.warnings.len(),
                        t.elapsed()
                    );
                    for wn in w.warnings.iter().take(400) {
                        if !wn.message.contains("defined but not used") {
                            println!("   {wn}");
                        }
                    }
                    let mut unused = std::collections::BTreeMap::<String, usize>::new();
                    for wn in &w.warnings {
                        if wn.message.contains("defined but not used") {
                            *unused
                                .entry(wn.message.split('`').nth(1).unwrap_or("").to_string())
                                .or_default() += 1;
                        }
                    }
                    println!("   unused: {unused:?}");
                }
                Err(e) => println!("ERR {}\n{e}", p.display()),
            }
        }
    }
    let _ = Dialect::World;
}
