//! Plumbing below every stage: reading input files within size limits ([`input`]), writing
//! outputs atomically ([`output`]), the settings an error's fix can name ([`setting`]), SIMD
//! lane blocks for the fit's kernels (`lanes`), PNG encoding with the embedded font (`png`) and
//! text drawn on bitmaps with that font ([`glyphs`]).

// Public for the binary and the integration tests (separate crates), not library API.
pub mod glyphs;
#[doc(hidden)]
pub mod input;
pub(crate) mod lanes;
pub mod output;
pub(crate) mod png;
// Public for the binary and the integration tests (separate crates), not library API.
#[doc(hidden)]
pub mod setting;
