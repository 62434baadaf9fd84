//! The levels of every test the diagnosis makes, derived once from α (`diagnosis.alpha`) and from
//! what is being judged. Each level is a Bonferroni share of α, so that every claim the verdict
//! makes — model error, a cause, a discovered term — is made at level α in all.
//!
//! | test | level | why |
//! |---|---|---|
//! | the uncorrected model's two lack-of-fit tests, detecting | α/4 each | detection shares α between the base's fit (α/2) and the candidates (α/2) |
//! | the K candidates' amplitude tests together, detecting | α/2, so α/(2K) each | the other half of α |
//! | a model judged for a cause (not detecting) | α | one claim |
//! | a named cause confirmed against each of R rivals (either direction) | α/R | the data chose the leader among R + 1: any of the R others could be the one that beats a true rival (Bonferroni) |
//! | a discovered model among M tried | α/M | the search pays for its size |
//! | the noise model's mixing set | α/10 | a set of the mixings the replicates do not reject, wide on purpose |

/// The levels of one diagnosis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Levels {
    /// The one significance level every claim is made at.
    pub alpha: f64,
    /// Detecting model error (the uncorrected model judged): α is shared as above.
    pub detection: bool,
}

/// The noise model's mixing set is at this share of α ([`Levels::mixing_set`]).
pub const MIXING_SET_SHARE: f64 = 0.1;

impl Levels {
    pub fn new(alpha: f64, detection: bool) -> Levels {
        Levels { alpha, detection }
    }

    /// The level of the K candidates' amplitude tests together: detecting model error, the
    /// candidates and the uncorrected model's lack of fit share α (half each, Bonferroni), so that
    /// model error is claimed at level α; judging a loop model, α.
    pub fn candidates(&self) -> f64 {
        if self.detection { self.alpha / 2.0 } else { self.alpha }
    }

    /// The level of one of `k` candidates' amplitude tests (Bonferroni over them): what "explains the
    /// misfit" needs, and what a test telling a candidate from no correction must reach.
    pub fn amplitude(&self, k: usize) -> f64 {
        self.candidates() / k.max(1) as f64
    }

    /// The level of each of the two lack-of-fit tests of the base model: detecting model error,
    /// the base shares its half of α between them (α/4 each); any other model's fit is a claim
    /// about a cause, each test at α.
    pub fn base_fit(&self) -> f64 {
        if self.detection { self.alpha / 4.0 } else { self.alpha }
    }

    /// The level of each of `rivals` tests that confirm a cause against its rivals, and of each
    /// test of a rival's shape still adding to the cause: α/R, since the data chose the leader.
    pub fn rival(&self, rivals: usize) -> f64 {
        self.alpha / rivals.max(1) as f64
    }

    /// The level of one of `models` models a search tried (Bonferroni over the search).
    pub fn searched(&self, models: usize) -> f64 {
        self.alpha / models.max(1) as f64
    }

    /// The levels as `results.json` records them (`diagnosis.levels`).
    pub fn record(&self) -> super::LevelsRecord {
        super::LevelsRecord {
            alpha: self.alpha,
            uncorrected_fit: self.base_fit(),
            candidates: self.candidates(),
            // A cause's model is judged on its own: each of its tests at α.
            cause_fit: self.alpha,
        }
    }

    /// The level of the noise model's set of mixings the replicates do not reject.
    pub fn mixing_set(&self) -> f64 {
        self.alpha * MIXING_SET_SHARE
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn detection_shares_alpha_between_the_base_and_the_candidates() {
        let d = Levels::new(0.05, true);
        // The base's two tests and the candidates' family add up to α.
        assert!((2.0 * d.base_fit() + d.candidates() - 0.05).abs() < 1e-15);
        assert!((d.amplitude(5) * 5.0 - d.candidates()).abs() < 1e-15);
        let judged = Levels::new(0.05, false);
        assert_eq!((judged.candidates(), judged.base_fit()), (0.05, 0.05));
        assert_eq!(judged.rival(0), 0.05);
        assert!((judged.rival(4) - 0.0125).abs() < 1e-15);
        assert!((judged.searched(10) - 0.005).abs() < 1e-15);
        assert!((judged.mixing_set() - 0.005).abs() < 1e-15);
    }
}
