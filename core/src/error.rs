//! The error values every fallible step returns. Small and `Copy`, so the firmware can count them.

/// Why a sample, a setting or a query was refused.
///
/// A refused sample leaves the estimator state exactly as it was (bit for bit).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// An input element is NaN or ±∞. `index` is the regressor index; `index == n_θ` is the output `z`.
    NonFinite {
        /// Position in `[x, z]`.
        index: u8,
    },
    /// An input element's magnitude exceeds the configured bound (`max_abs_input`).
    OutOfRange {
        /// Position in `[x, z]`.
        index: u8,
    },
    /// A matrix that must be symmetric positive definite (e.g. `W_T`, eq. 9) is not.
    NotPositiveDefinite,
    /// A setting is outside its documented range.
    InvalidSetting,
    /// The update produced a non-finite or invalid state and was rolled back.
    NumericalFault,
    /// The data do not determine every parameter (k < n_θ, eq. 21): the requested quantity (e.g.
    /// the covariance of eq. 17) is not defined.
    InsufficientExcitation,
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::NonFinite { index } => write!(f, "input element {index} is NaN or infinite"),
            Error::OutOfRange { index } => write!(f, "input element {index} exceeds the configured magnitude bound"),
            Error::NotPositiveDefinite => f.write_str("matrix is not symmetric positive definite"),
            Error::InvalidSetting => f.write_str("setting outside its documented range"),
            Error::NumericalFault => f.write_str("update produced a non-finite state and was rolled back"),
            Error::InsufficientExcitation => f.write_str("insufficient excitation: not every parameter is determined"),
        }
    }
}
