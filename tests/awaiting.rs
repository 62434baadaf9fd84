//! The test files that mostly wait: on Slurm scheduling jobs that sleep, on a hung solver's
//! timeout, on a terminal's question. They sit under this module so that they start first: libtest
//! starts tests in the order of their names, and at the start of CI the seeded families run beside
//! the suite (.ci/run), so the cores these tests leave idle are used. At the end of the suite they
//! left a core idle for about two minutes.

#[path = "failed_runs.rs"]
mod failed_runs;
#[path = "slurm_interrupt.rs"]
mod slurm_interrupt;
#[path = "slurm_live.rs"]
mod slurm_live;
