//! Helpers shared by the integration tests: small scenes built in code whose answer is known
//! (`scenes`), the chi-square goodness-of-fit harness every sampler test uses (`chi2`), glTF
//! files packed in memory (`gltf`), and running the `photon` binary on committed scenes in a
//! fresh directory per test (`binary`).

pub mod binary;
pub mod chi2;
pub mod gltf;
pub mod scenes;
