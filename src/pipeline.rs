//! `lab run`: study → model → calibrate → report.
