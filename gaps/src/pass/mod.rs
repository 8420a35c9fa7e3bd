//! The analysis as one straight pass ([`crate::run_gaps`]): a stage per module, in order, each
//! handing the next a typed result.
//!
//! | stage | module | hands on |
//! |---|---|---|
//! | the flight checked, at the analysis rate, α and β chosen; step sizes, split, thresholds | [`prepare`] | [`prepare::Prepared`] |
//! | the flight-path reconstruction and the sensor errors it names | [`compatibility`] | [`compatibility::Compatible`] |
//! | the air data of the regressors (sensors, reconstruction or their fusion) | [`air_data`] | [`air_data::AirData`] |
//! | the coefficients' table, the terms' columns and their errors in variables | [`synthesis`] | [`synthesis::Synthesised`] |
//! | each coefficient's baseline fit and stepwise extension | [`selection`] | [`selection::Selected`] |
//! | the held-out simulation, the manoeuvres, the baselines as logged | [`validation`] | [`validation::Validated`] |
//! | the named causes, the data quality and the verdict | [`report`] | [`crate::GapReport`] |
//!
//! The notes (what was done, in words) are one list, in the report's order, that the stages add
//! to as they go.

pub mod air_data;
pub mod compatibility;
pub mod prepare;
pub mod report;
pub mod selection;
pub mod synthesis;
pub mod validation;
