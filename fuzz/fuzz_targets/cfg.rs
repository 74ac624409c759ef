//! A Player `.cfg` from anyone: lexer, parser and includes (the input is a small tree of files,
//! see `write_tree`), driver blocks with their `provides`/`requires` addresses, then the
//! server's translation of each block into a `DriverBlock` (addresses in wire form).
//!
//! Checks beyond "no panic": loading the file and parsing its text as that file agree; every
//! device address the cfg accepted prints (`describe`) and its text parses back to the same
//! interface, index and port; a block whose addresses all parsed translates without a lookup.

#![no_main]

use libfuzzer_sys::fuzz_target;
use playerstage_fuzz::{load_options, top_part, write_tree};
use worldfile::{CfgFile, Host};

fuzz_target!(|data: &[u8]| {
    let top = write_tree(data, "main.cfg");
    let opts = load_options();
    let loaded = CfgFile::load(&top, &opts);
    if let Ok(text) = std::str::from_utf8(top_part(data)) {
        let parsed = CfgFile::parse(&top, text, &opts);
        match (&loaded, &parsed) {
            (Ok(a), Ok(b)) => assert_eq!(a.drivers.len(), b.drivers.len()),
            (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
            _ => panic!("load and parse disagree"),
        }
    }
    let cfg = match loaded {
        Ok(cfg) => cfg,
        Err(e) => {
            assert!(!e.to_string().is_empty());
            return;
        }
    };
    for d in &cfg.drivers {
        for a in d.provides.iter().chain(&d.requires) {
            let _ = a.describe(6665);
            let again = worldfile::DeviceAddr::parse(&a.text)
                .unwrap_or_else(|e| panic!("accepted {:?} but it does not re-parse: {e}", a.text));
            assert_eq!(
                (again.interface, again.index, again.port_or(6665)),
                (a.interface, a.index, a.port_or(6665)),
                "{:?}",
                a.text
            );
            let _ = a.old_name_warning();
        }
        let _ = cfg.worldfile_path(d);
        // a name would be looked up in DNS: only blocks without one are translated
        let no_lookup = d
            .provides
            .iter()
            .chain(&d.requires)
            .all(|a| !matches!(a.host, Host::Name(_)) || a.host.ipv4().is_some());
        if no_lookup {
            let _ = player_server::cfg::driver_block(&cfg, d, 6665);
        }
    }
});
