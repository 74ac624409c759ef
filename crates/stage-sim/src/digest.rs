//! The determinism digest: an FNV-1a fold of every value a model's state holds, so that equal
//! digests mean equal states (same world, seed and commands give the same digest whatever the
//! thread count; a change that must not alter results keeps every bench world's digest).

use crate::color::Color;
use crate::node::ModelId;
use crate::pose::Pose;

/// A running digest; each model type feeds its own state ([`crate::World::state_digest`]).
pub(crate) struct Digest(u64);

impl Digest {
    pub(crate) fn new() -> Digest {
        Digest(0xcbf2_9ce4_8422_2325)
    }

    pub(crate) fn u64(&mut self, v: u64) {
        self.0 ^= v;
        self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
    }

    pub(crate) fn f64(&mut self, x: f64) {
        self.u64(x.to_bits());
    }

    pub(crate) fn pose(&mut self, p: &Pose) {
        for v in [p.x, p.y, p.z, p.a] {
            self.f64(v);
        }
    }

    pub(crate) fn color(&mut self, c: &Color) {
        for v in [c.r, c.g, c.b, c.a] {
            self.f64(v);
        }
    }

    pub(crate) fn model(&mut self, m: Option<ModelId>) {
        self.u64(m.map_or(u64::MAX, |m| m.0 as u64));
    }

    pub(crate) fn bytes(&mut self, b: &[u8]) {
        self.u64(b.len() as u64);
        for c in b.chunks(8) {
            let mut w = [0u8; 8];
            w[..c.len()].copy_from_slice(c);
            self.u64(u64::from_le_bytes(w));
        }
    }

    pub(crate) fn finish(&self) -> u64 {
        self.0
    }
}
