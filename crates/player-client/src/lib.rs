//! A Rust Player client library in the spirit of libplayerc++.
