//! The world's seeded random numbers. One seed per world; every model draws from its own stream
//! derived from `(seed, model index)`, so results never depend on the order in which models run
//! (and runs are bit-for-bit repeatable, unlike Stage's clock-seeded `drand48`, spec §5.8).

/// SplitMix64 finaliser: a strong 64-bit mix used to derive independent stream seeds.
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A small, fast xoshiro256** generator; deterministic on every platform.
#[derive(Clone, Debug)]
pub struct SimRng {
    s: [u64; 4],
}

impl SimRng {
    /// A generator for `(seed, stream)`; different streams are statistically independent.
    pub fn new(seed: u64, stream: u64) -> SimRng {
        let mut z = mix64(seed ^ mix64(stream.wrapping_add(0x9e37_79b9_7f4a_7c15)));
        let mut s = [0u64; 4];
        for w in &mut s {
            z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
            *w = mix64(z);
        }
        if s == [0; 4] {
            s[0] = 1;
        }
        SimRng { s }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let result = self.s[1].wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = self.s[1] << 17;
        self.s[2] ^= self.s[0];
        self.s[3] ^= self.s[1];
        self.s[1] ^= self.s[2];
        self.s[0] ^= self.s[3];
        self.s[2] ^= t;
        self.s[3] = self.s[3].rotate_left(45);
        result
    }

    /// Uniform in `[0, 1)` (like `drand48`).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next_f64()
    }

    /// Uniform integer in `0..n` (`n > 0`), like `random() % n` without its bias.
    pub fn below(&mut self, n: u32) -> u32 {
        (((self.next_u64() >> 32) * n as u64) >> 32) as u32
    }

    /// A zero-mean normal variate with standard deviation `sd` (Box–Muller).
    pub fn normal(&mut self, sd: f64) -> f64 {
        let u1 = 1.0 - self.next_f64();
        let u2 = self.next_f64();
        sd * (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_repeatable_and_distinct() {
        let a: Vec<u64> = (0..4).map(|_| SimRng::new(7, 3).next_u64()).collect();
        assert!(a.iter().all(|&v| v == a[0]));
        let mut r1 = SimRng::new(7, 3);
        let mut r2 = SimRng::new(7, 4);
        let mut r3 = SimRng::new(8, 3);
        let x1: Vec<u64> = (0..8).map(|_| r1.next_u64()).collect();
        let x2: Vec<u64> = (0..8).map(|_| r2.next_u64()).collect();
        let x3: Vec<u64> = (0..8).map(|_| r3.next_u64()).collect();
        assert_ne!(x1, x2);
        assert_ne!(x1, x3);
    }

    #[test]
    fn uniform_stays_in_range_and_covers_it() {
        let mut r = SimRng::new(1, 1);
        let mut lo = f64::MAX;
        let mut hi = f64::MIN;
        for _ in 0..10_000 {
            let v = r.uniform(-0.5, 0.5);
            assert!((-0.5..0.5).contains(&v));
            lo = lo.min(v);
            hi = hi.max(v);
        }
        assert!(lo < -0.49 && hi > 0.49);
        for _ in 0..1000 {
            assert!(r.below(10) < 10);
        }
    }
}
