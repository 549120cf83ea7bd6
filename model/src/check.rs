//! Field-by-field range checks, shared by the run configuration and by
//! workers checking the parameters a job brings.

/// A parameter out of range: its name (`section.key`) and what is wrong.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{field} {problem}")]
pub struct ParamError {
    pub field: &'static str,
    pub problem: String,
}

/// Finite and no more than `max`.
pub fn at_most(field: &'static str, v: f64, max: f64) -> Result<(), ParamError> {
    finite(field, v)?;
    check(
        field,
        v <= max,
        format_args!("must be at most {max:e} (got {v:?})"),
    )
}

/// Finite and no more than `size` either side of zero.
pub fn within(field: &'static str, v: f64, size: f64) -> Result<(), ParamError> {
    finite(field, v)?;
    check(
        field,
        v.abs() <= size,
        format_args!("must be from -{size:e} to {size:e} (got {v:?})"),
    )
}

/// `problem` is only written out when `ok` is false: workers check every
/// job's parameters, and formatting each message every time would cost a
/// job microseconds.
pub fn check(
    field: &'static str,
    ok: bool,
    problem: impl std::fmt::Display,
) -> Result<(), ParamError> {
    if ok {
        Ok(())
    } else {
        Err(ParamError {
            field,
            problem: problem.to_string(),
        })
    }
}

pub fn finite(field: &'static str, v: f64) -> Result<(), ParamError> {
    check(
        field,
        v.is_finite(),
        format_args!("must be a finite number (got {v})"),
    )
}

pub fn positive(field: &'static str, v: f64) -> Result<(), ParamError> {
    finite(field, v)?;
    check(
        field,
        v > 0.0,
        format_args!("must be greater than 0 (got {v})"),
    )
}

pub fn non_negative(field: &'static str, v: f64) -> Result<(), ParamError> {
    finite(field, v)?;
    check(
        field,
        v >= 0.0,
        format_args!("must not be negative (got {v})"),
    )
}

pub fn probability(field: &'static str, v: f64) -> Result<(), ParamError> {
    check(
        field,
        (0.0..=1.0).contains(&v),
        format_args!("must be in [0, 1] (got {v})"),
    )
}
