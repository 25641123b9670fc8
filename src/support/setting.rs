//! What a user can change to get past an error, named without any interface's syntax: library
//! errors carry one where it applies, and the command line words it as a flag (`src/cli/`).

/// A setting the user can change.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Setting {
    /// The policy for negative values (treat them as missing, or set them to 0).
    NegativePolicy,
    /// The file format, chosen instead of detected.
    Format,
    /// One channel (or the r, g, b channels) of a multi-channel data set.
    Channel,
    /// Hold the named parameter at a value.
    Hold(String),
    /// A start point for the fit.
    Start,
    /// Give the named parameter of a model a value.
    Value(String),
    /// The largest angle of the samples used.
    MaxTheta,
    /// The size limit of input files ([`crate::support::input`]).
    MaxInputSize,
}
