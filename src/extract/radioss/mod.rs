//! OpenRadioss outputs: the starter's and engine's listings ([`listing`]) and what lab takes from
//! the time history T01 ([`history`]: the crush curve, the energy figures, completeness). The T01
//! file itself is read by the workspace crate `radioss-th`.

pub mod history;
pub mod listing;
