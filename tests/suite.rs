//! Every integration test of `lab` in one test binary: the tests of all files share the machine's
//! cores instead of each file's binary running after the last (most files end on one long test and
//! would leave a core idle), and the library is linked once instead of once per file.
//! A file's tests run alone with a filter on its module, e.g.
//! `cargo test --release --test suite -- confirmation::`. One file keeps a binary of its own:
//! tests/execute_signal.rs signals its own process.

// Helpers the test files share (one crate: a helper no file uses is dead code, and said so).
mod beam_common;
mod ccx_common;
mod common;
mod crushsim_bin;
mod damage;
mod family_runs;
mod fixed_design;
mod power_common;
mod readers;
mod slurm_common;
mod solvers;
mod verdict_common;

// The test files, one module each; those that mostly wait are under `awaiting`, to start first.
mod awaiting;
mod bad_input;
mod bad_solver_input;
mod binout_extract;
mod binout_lasso;
mod binout_study;
mod calculix_honeycomb;
mod calculix_live;
mod cantilever;
mod ccx_clamp;
mod compare_cli;
mod confirmation;
mod corruption;
mod curve_metrics_reference;
mod curves_family;
mod deck_as_is;
mod deck_honeycomb;
mod deck_mesh;
mod deck_pydyna;
mod deck_template;
mod diagnose_discover;
mod diagnose_hidden;
mod diagnose_noise;
mod diagnose_paper;
mod diagnosis_studies;
mod docs_links;
mod execute_lock;
mod execute_runs;
mod execute_store;
mod extension;
mod extract_crush;
mod extract_lsdyna;
mod extract_props;
mod honeycomb_diagnosis;
mod honeycomb_study;
mod loop_verdict;
mod next_test_programme;
mod not_excluded;
mod openradioss_adapter;
mod openradioss_live;
mod openradioss_study;
mod output_checks;
mod report_browser;
mod scale_study;
mod solver_scatter;
mod solver_study;
mod study_curves;
