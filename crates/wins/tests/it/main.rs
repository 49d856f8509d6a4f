//! Integration tests of the wins library (one test binary).

mod data;
mod intel5300_corrupt;
mod intel5300_real;
mod intel5300_roundtrip;
