//! Typed parameter spaces of the built-in shaders [references: bourque §4.6]: every parameter
//! has a type (a float or angle range, an integer range, a colour), a default and a flag saying
//! whether a search may move it. The thesis treated every parameter as a float, which is why
//! its integer star shader could not be matched (Fig. 4-21); typing them fixes that by design.
//!
//! A parameter vector is flat: one `f64` per float, angle or integer parameter and three per
//! colour, in the order of the shader's table.

use serde::{Deserialize, Serialize};

/// The type and range of one parameter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum ParamKind {
    /// A real number in `[min, max]`.
    Float { min: f64, max: f64 },
    /// An angle in radians in `[min, max]` (written in degrees in scenes).
    Angle { min: f64, max: f64 },
    /// A whole number in `[min, max]`.
    Int { min: i64, max: i64 },
    /// An RGB colour, each channel in `[0, 1]`.
    Colour,
}

impl ParamKind {
    /// How many entries of the flat vector it takes.
    pub fn width(self) -> usize {
        match self {
            ParamKind::Colour => 3,
            _ => 1,
        }
    }

    /// The range of each of its entries.
    pub fn bounds(self) -> (f64, f64) {
        match self {
            ParamKind::Float { min, max } | ParamKind::Angle { min, max } => (min, max),
            ParamKind::Int { min, max } => (min as f64, max as f64),
            ParamKind::Colour => (0.0, 1.0),
        }
    }
}

/// One parameter of a shader.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ParamDef {
    pub name: &'static str,
    pub kind: ParamKind,
    /// The default: one value, or three for a colour.
    pub default: &'static [f64],
    /// Whether matching searches it by default (lighting constants and colours do not: the
    /// thesis's GUI left them unticked, and a grey-level metric cannot see colour).
    pub search: bool,
    pub doc: &'static str,
}

impl ParamDef {
    pub const fn float(name: &'static str, min: f64, max: f64, default: &'static [f64], doc: &'static str) -> Self {
        ParamDef { name, kind: ParamKind::Float { min, max }, default, search: true, doc }
    }

    pub const fn angle(name: &'static str, min: f64, max: f64, default: &'static [f64], doc: &'static str) -> Self {
        ParamDef { name, kind: ParamKind::Angle { min, max }, default, search: true, doc }
    }

    pub const fn int(name: &'static str, min: i64, max: i64, default: &'static [f64], doc: &'static str) -> Self {
        ParamDef { name, kind: ParamKind::Int { min, max }, default, search: true, doc }
    }

    pub const fn colour(name: &'static str, default: &'static [f64], doc: &'static str) -> Self {
        ParamDef { name, kind: ParamKind::Colour, default, search: false, doc }
    }

    /// The same parameter, left alone by searches unless a scene enables it.
    pub const fn fixed(self) -> Self {
        ParamDef { search: false, ..self }
    }
}

/// Why a parameter vector does not fit its shader.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ParamError {
    #[error("the shader takes {expected} values, not {got}")]
    Length { expected: usize, got: usize },
    #[error("`{name}` = {value} is outside [{min}, {max}]")]
    Range { name: &'static str, value: f64, min: f64, max: f64 },
    #[error("`{name}` is a whole number, not {value}")]
    NotInteger { name: &'static str, value: f64 },
}

/// The flat vector of the defaults.
pub fn defaults(params: &[ParamDef]) -> Vec<f64> {
    params.iter().flat_map(|p| p.default.iter().copied()).collect()
}

/// Total flat length.
pub fn flat_len(params: &[ParamDef]) -> usize {
    params.iter().map(|p| p.kind.width()).sum()
}

/// Offset of each parameter in the flat vector.
pub fn offsets(params: &[ParamDef]) -> Vec<usize> {
    params
        .iter()
        .scan(0, |at, p| {
            let here = *at;
            *at += p.kind.width();
            Some(here)
        })
        .collect()
}

/// Checks a flat vector: its length, every value inside its range and finite, integers whole.
pub fn validate(params: &[ParamDef], values: &[f64]) -> Result<(), ParamError> {
    let expected = flat_len(params);
    if values.len() != expected {
        return Err(ParamError::Length { expected, got: values.len() });
    }
    for (p, at) in params.iter().zip(offsets(params)) {
        let (min, max) = p.kind.bounds();
        for &value in &values[at..at + p.kind.width()] {
            // `!(a <= b)` also refuses NaN.
            if !(min <= value && value <= max) {
                return Err(ParamError::Range { name: p.name, value, min, max });
            }
            if matches!(p.kind, ParamKind::Int { .. }) && value.fract() != 0.0 {
                return Err(ParamError::NotInteger { name: p.name, value });
            }
        }
    }
    Ok(())
}

/// Reads a flat vector in table order: each call takes the next parameter.
pub(crate) struct Args<'a> {
    values: &'a [f64],
    at: usize,
}

impl<'a> Args<'a> {
    pub fn new(values: &'a [f64]) -> Self {
        Args { values, at: 0 }
    }

    pub fn f(&mut self) -> f64 {
        self.at += 1;
        self.values[self.at - 1]
    }

    pub fn c(&mut self) -> [f32; 3] {
        self.at += 3;
        let v = &self.values[self.at - 3..self.at];
        [v[0] as f32, v[1] as f32, v[2] as f32]
    }
}
