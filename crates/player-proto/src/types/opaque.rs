//! The `opaque` interface (51): application-defined bytes (Player's `opaque.def`).

xdr_struct! {
    /// Bytes whose meaning the application defines (DATA STATE, CMD DATA, REQ DATA).
    pub struct OpaqueData = "player_opaque_data_t" {
        /// The bytes.
        data: Vec<u8>,
    }
}
