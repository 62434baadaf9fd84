//! The one place that knows which YAML crate parses study files (serde-saphyr).
