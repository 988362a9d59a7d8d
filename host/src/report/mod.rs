//! The pieces of the JSON reports that `identify`, `diagnose` and `board` share: a reported
//! number ([`Num`]), one parameter's estimate ([`ParamEstimate`]) and parameters by name
//! ([`ByParam`]); the `identify` report itself ([`identify`]) and its text summary
//! ([`summary`]).

pub mod board;
pub mod identify;
pub mod summary;

use motor_id_shared::fit::identifiability::{Identifiability, ParamCertainty};
use motor_id_shared::ParamId;
use serde::ser::{Serialize, SerializeMap, Serializer};

/// Version of the JSON reports' schema (`identify`, `diagnose`, `board`): bumped when a field
/// changes meaning or goes; fields are added without a bump (`docs/CONTRACTS.md`).
pub const SCHEMA_VERSION: u32 = 1;

/// An f32 as a report gives it: in JSON the shortest decimal that reads back to it, `null`
/// when it is not finite.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Num(pub f32);

impl Num {
    /// The number the JSON holds: the shortest decimal of the f32, read as f64; NaN for
    /// `null`.
    pub fn decimal(self) -> f64 {
        if self.0.is_finite() {
            self.0.to_string().parse().unwrap_or(self.0 as f64)
        } else {
            f64::NAN
        }
    }
}

impl Serialize for Num {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.0.is_finite() {
            s.serialize_f64(self.decimal())
        } else {
            s.serialize_none()
        }
    }
}

/// One parameter's estimate: its value, whether the data pins it, and its standard
/// deviation (`null` when unknown).
#[derive(serde::Serialize, Clone, Copy, Debug, PartialEq)]
pub struct ParamEstimate {
    /// Estimate.
    pub value: Num,
    /// Whether the data pins it.
    pub pinned: bool,
    /// One standard deviation, in the parameter's unit.
    pub std: Option<Num>,
}

impl ParamEstimate {
    /// What the identifiability analysis says of one free parameter.
    pub fn of(c: &ParamCertainty) -> ParamEstimate {
        ParamEstimate {
            value: Num(c.value),
            pinned: c.pinned,
            std: c.std.map(Num),
        }
    }

    /// A value with a standard deviation that is not finite when the data does not pin it
    /// (as a board reports them).
    pub fn with_std(value: f32, std: f32) -> ParamEstimate {
        ParamEstimate {
            value: Num(value),
            pinned: std.is_finite(),
            std: Some(Num(std)),
        }
    }
}

/// Values by parameter, in the order given; a JSON object keyed by the parameters' names.
#[derive(Clone, Debug, PartialEq)]
pub struct ByParam<T>(pub Vec<(ParamId, T)>);

impl<T> ByParam<T> {
    /// The entries in order.
    pub fn iter(&self) -> impl Iterator<Item = &(ParamId, T)> {
        self.0.iter()
    }
}

impl<T> FromIterator<(ParamId, T)> for ByParam<T> {
    fn from_iter<I: IntoIterator<Item = (ParamId, T)>>(iter: I) -> ByParam<T> {
        ByParam(iter.into_iter().collect())
    }
}

impl<T: Serialize> Serialize for ByParam<T> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(self.0.len()))?;
        for (id, v) in &self.0 {
            map.serialize_entry(id.name(), v)?;
        }
        map.end()
    }
}

/// The estimate of every free parameter of an identification.
pub fn estimates(ident: &Identifiability) -> ByParam<ParamEstimate> {
    ident
        .params
        .iter()
        .map(|c| (c.id, ParamEstimate::of(c)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_shortest_decimals_and_null_when_not_finite() {
        assert_eq!(Num(0.1).decimal(), 0.1);
        assert_eq!(
            serde_json::to_string(&Num(2.0885514e-6)).unwrap(),
            "2.0885514e-6"
        );
        assert_eq!(serde_json::to_string(&Num(f32::NAN)).unwrap(), "null");
        let est = ParamEstimate::with_std(3.5, f32::INFINITY);
        assert!(!est.pinned);
        let by: ByParam<ParamEstimate> = [(ParamId::Tc, est)].into_iter().collect();
        assert_eq!(
            serde_json::to_string(&by).unwrap(),
            r#"{"tc":{"value":3.5,"pinned":false,"std":null}}"#
        );
    }
}
