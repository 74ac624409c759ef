//! Python exceptions raised by the native module, and the mapping from the workspace's error
//! types. One base class, `PlayerError`, so scripts can catch everything with one clause, and
//! subclasses for the cases a caller handles differently (a lost server, a refused request).

use player_client::ClientError;
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    _native,
    PlayerError,
    PyException,
    "Anything that went wrong talking to a Player server or loading a world."
);
create_exception!(
    _native,
    ConnectionLost,
    PlayerError,
    "The server closed the connection or the socket failed: the client is unusable."
);
create_exception!(
    _native,
    RequestRefused,
    PlayerError,
    "The server answered a request with NACK (no such device, unsupported request)."
);
create_exception!(
    _native,
    RequestTimeout,
    PlayerError,
    "No reply (or no data) within the timeout."
);
create_exception!(
    _native,
    WorldError,
    PlayerError,
    "A worldfile could not be loaded (the message names file:line), or a model is missing."
);

/// Adds the exception classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("PlayerError", py.get_type::<PlayerError>())?;
    m.add("ConnectionLost", py.get_type::<ConnectionLost>())?;
    m.add("RequestRefused", py.get_type::<RequestRefused>())?;
    m.add("RequestTimeout", py.get_type::<RequestTimeout>())?;
    m.add("WorldError", py.get_type::<WorldError>())?;
    Ok(())
}

/// The Python exception for a client error, carrying its message (which names the peer or
/// the request).
pub fn client_err(e: ClientError) -> PyErr {
    let msg = e.to_string();
    match e {
        ClientError::Closed | ClientError::Io(_) | ClientError::Connect { .. } => {
            ConnectionLost::new_err(msg)
        }
        ClientError::Banner { .. } => ConnectionLost::new_err(msg),
        ClientError::Nack { .. } | ClientError::Subscribe { .. } => RequestRefused::new_err(msg),
        ClientError::Timeout { .. } => RequestTimeout::new_err(msg),
        _ => PlayerError::new_err(msg),
    }
}
