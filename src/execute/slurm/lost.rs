//! When a Slurm job counts as lost.
//!
//! `lab` learns a job's state from squeue, then `scontrol show job`, then the jobcomp record (the
//! first two forget a job MinJobAge after its end). A job none of the three knows — its controller
//! lost its state, the jobcomp file was rotated away while `lab` was not watching — would be waited
//! on forever. Instead it is *lost* once it has been absent from all three, with Slurm answering,
//! for `slurm.lost_after` seconds: its unfinished runs get the `lost` outcome and are resubmitted
//! by the next `lab run --executor slurm`.
//!
//! The decision is a pure fold over what the polls saw, with the clock passed in, so it is tested
//! here without Slurm. The executor path is tested twice: a unit test of the collection step in
//! `slurm/mod.rs`, and `tests/slurm_live.rs` against a real Slurm with a journaled job id that no
//! source knows (making a real job vanish — scancel, wait out MinJobAge, truncate the jobcomp
//! file — is too slow and too intrusive for a test).

use std::time::Duration;

/// What one poll said about a job.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sighting {
    /// squeue, scontrol or the jobcomp record knows the job.
    Known,
    /// Slurm answered and none of the three knows the job.
    Absent,
    /// Slurm did not answer (controller down or unreachable): nothing is learnt about the job.
    NoAnswer,
}

/// The decision after a poll.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Known to Slurm, or nothing learnt: keep waiting.
    Present,
    /// Absent for `absent_ms` so far, less than the grace period.
    Missing { absent_ms: u64 },
    /// Absent for `absent_ms`, at least the grace period: give up on the job.
    Lost { absent_ms: u64 },
}

/// One job's watch: when its current absence began.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Watch {
    absent_since_ms: Option<u64>,
}

impl Watch {
    /// Folds in the sighting of a poll made at `now_ms`.
    ///
    /// An absence counts only while it is seen without a break: a poll that finds the job, or one
    /// Slurm did not answer, starts the count again. Why a missing answer resets rather than
    /// pauses: while the controller is down or restarting, a job can come back; a job is only
    /// given up after `lost_after` of Slurm steadily saying it does not know it.
    pub fn observe(&mut self, sighting: Sighting, now_ms: u64, lost_after: Duration) -> Verdict {
        match sighting {
            Sighting::Known | Sighting::NoAnswer => {
                self.absent_since_ms = None;
                Verdict::Present
            }
            Sighting::Absent => {
                let since = *self.absent_since_ms.get_or_insert(now_ms);
                let absent_ms = now_ms.saturating_sub(since);
                if u128::from(absent_ms) >= lost_after.as_millis() {
                    Verdict::Lost { absent_ms }
                } else {
                    Verdict::Missing { absent_ms }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Sighting::*;
    use super::*;

    /// The verdict after a whole history of `(poll time in ms, sighting)`, oldest first.
    fn verdict(history: &[(u64, Sighting)], lost_after: Duration) -> Verdict {
        let mut watch = Watch::default();
        history
            .iter()
            .fold(Verdict::Present, |_, &(t, s)| watch.observe(s, t, lost_after))
    }

    const GRACE: Duration = Duration::from_secs(120);

    #[test]
    fn a_known_job_is_never_lost() {
        let h: Vec<(u64, Sighting)> = (0..1000).map(|i| (i * 2_000, Known)).collect();
        assert_eq!(verdict(&h, GRACE), Verdict::Present);
    }

    #[test]
    fn lost_exactly_when_absent_for_the_grace_period() {
        let h = [(1_000, Known), (3_000, Absent), (60_000, Absent), (122_999, Absent)];
        assert_eq!(verdict(&h, GRACE), Verdict::Missing { absent_ms: 119_999 });
        let h = [(1_000, Known), (3_000, Absent), (60_000, Absent), (123_000, Absent)];
        assert_eq!(verdict(&h, GRACE), Verdict::Lost { absent_ms: 120_000 });
    }

    #[test]
    fn a_job_seen_again_starts_the_count_again() {
        let h = [(0, Absent), (100_000, Known), (110_000, Absent), (200_000, Absent)];
        assert_eq!(verdict(&h, GRACE), Verdict::Missing { absent_ms: 90_000 });
        let h = [(0, Absent), (100_000, Known), (110_000, Absent), (230_000, Absent)];
        assert_eq!(verdict(&h, GRACE), Verdict::Lost { absent_ms: 120_000 });
    }

    #[test]
    fn slurm_not_answering_is_no_evidence() {
        // The controller is down for ten minutes: the job is not lost, whatever the clock says.
        let mut h: Vec<(u64, Sighting)> = vec![(0, Absent)];
        h.extend((1..=300).map(|i| (i * 2_000, NoAnswer)));
        assert_eq!(verdict(&h, GRACE), Verdict::Present);
        // It answers again, without the job: the count starts at that answer.
        h.push((602_000, Absent));
        assert_eq!(verdict(&h, GRACE), Verdict::Missing { absent_ms: 0 });
        h.push((722_000, Absent));
        assert_eq!(verdict(&h, GRACE), Verdict::Lost { absent_ms: 120_000 });
    }

    #[test]
    fn a_clock_stepping_back_does_not_underflow() {
        let h = [(50_000, Absent), (10_000, Absent)];
        assert_eq!(verdict(&h, GRACE), Verdict::Missing { absent_ms: 0 });
    }

    #[test]
    fn a_zero_grace_gives_up_at_the_first_absence() {
        assert_eq!(verdict(&[(5, Absent)], Duration::ZERO), Verdict::Lost { absent_ms: 0 });
    }
}
