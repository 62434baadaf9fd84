//! The study file's YAML schema (serde), before validation.
