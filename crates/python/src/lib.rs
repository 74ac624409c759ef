//! The native half of the Python 3 package `playerstage` (built by maturin as
//! `playerstage._native`).
//!
//! It is deliberately thin: [`client::Connection`] is the workspace's `player-client` (one
//! codec, libplayerc's session rules) with one method per Player request or command the Python
//! modules need, and [`world::World`] is `stage-sim` stepped in-process. Everything
//! user-facing — the drop-in `playerc` / `playercpp` modules and the Pythonic
//! `playerstage.Client` — is pure Python over these two classes, so the wire format and the
//! simulation exist once, in Rust.

use pyo3::prelude::*;

pub mod client;
pub mod convert;
pub mod errors;
pub mod explore;
pub mod vector;
pub mod world;

/// The module's contents: the two classes, the functions that step many worlds at once for
/// `playerstage.envs.VectorStageEnv` ([`world::step_worlds`], [`world::step_observe`]) and
/// its native step ([`vector::VectorCore`]; the goal task's reward, [`vector::goal_reward`]),
/// the exception hierarchy, the interface codes the Python side addresses devices with, and
/// Player's default port (`DEFAULT_PORT`, so the Python modules' defaults come from the one
/// Rust constant).
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<client::Connection>()?;
    m.add_class::<world::World>()?;
    m.add_function(wrap_pyfunction!(world::step_worlds, m)?)?;
    m.add_function(wrap_pyfunction!(world::step_observe, m)?)?;
    m.add_function(wrap_pyfunction!(world::load_worlds, m)?)?;
    m.add_class::<vector::VectorCore>()?;
    m.add_function(wrap_pyfunction!(vector::goal_reward, m)?)?;
    m.add_function(wrap_pyfunction!(world::display_available, m)?)?;
    m.add_function(wrap_pyfunction!(world::close_window, m)?)?;
    m.add_function(wrap_pyfunction!(world::window_state, m)?)?;
    errors::register(m)?;
    m.add("DEFAULT_PORT", player_client::DEFAULT_PORT)?;
    for (name, code) in convert::INTERFACES {
        m.add(*name, code.0)?;
    }
    Ok(())
}
