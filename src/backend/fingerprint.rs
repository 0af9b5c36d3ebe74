//! A 64-bit multiply–rotate hash of words (the FxHash step): tells whether the inputs of an
//! operator, or the sparsity pattern of a matrix, changed since the last time they were seen.
//! Two different inputs hash alike with probability about 2⁻⁶⁴ for ordinary data; it is not
//! meant for adversarial input.

/// FxHash's multiplier (the golden-ratio constant of Firefox's hasher).
const MULTIPLIER: u64 = 0x51_7c_c1_b7_27_22_0a_95;

/// The running hash of the words added so far (0 before the first).
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Fingerprint(u64);

impl Fingerprint {
    /// Mixes `word` into the hash: h ← (rotl(h, 5) ⊕ word) · K.
    pub(crate) fn add(&mut self, word: u64) {
        self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(MULTIPLIER);
    }

    /// The hash of every word added.
    pub(crate) fn value(self) -> u64 {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hash_follows_the_fxhash_step_and_the_order_of_the_words() {
        let mut a = Fingerprint::default();
        a.add(1);
        // (rotl(0, 5) ⊕ 1) · K = K.
        assert_eq!(a.value(), MULTIPLIER);
        a.add(2);
        let mut b = Fingerprint::default();
        b.add(2);
        b.add(1);
        assert_ne!(a.value(), b.value(), "order matters");
        assert_eq!(
            a.value(),
            (MULTIPLIER.rotate_left(5) ^ 2).wrapping_mul(MULTIPLIER)
        );
    }
}
