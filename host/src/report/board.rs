//! What a board reports of a motor (`board identify`, `board commission`, `board params`,
//! `commission --sim`): the `identify` report's fields that a board sends, and the text of
//! a commissioning's plan.

use crate::report::{ByParam, Num, ParamEstimate};
use anyhow::{anyhow, Result};
use motor_id_shared::device::unpinned::why_not_pinned;
use motor_id_shared::param_id::ParamId;
use motor_id_shared::wire::protocol::{MotorReport, Plan};
use serde::Serialize;
use std::collections::BTreeMap;

/// What `board` reports of a motor: the `identify` report's fields that a board sends.
#[derive(Serialize, Debug)]
pub struct BoardReport {
    /// Version of this report's schema ([`crate::report::SCHEMA_VERSION`]).
    schema_version: u32,
    /// Motor parameters, and Coulomb friction when the board identified it.
    params: ByParam<Num>,
    /// Speed RMSE [rad/s].
    rmse_omega: Num,
    /// Model evaluations.
    evaluations: u32,
    /// What the data pins.
    identifiability: BoardIdentifiability,
    /// Why each parameter the data did not pin is not pinned (`board commission`; absent
    /// when empty).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    unpinned: BTreeMap<&'static str, String>,
}

/// The board's identifiability: rank and each parameter's estimate.
#[derive(Serialize, Debug)]
pub struct BoardIdentifiability {
    /// Directions the data pins.
    rank: u8,
    /// Parameters identified.
    free: usize,
    /// Every parameter's estimate.
    parameters: ByParam<ParamEstimate>,
}

impl BoardReport {
    /// The report of the board's message; an estimate of a parameter this host does not
    /// know (a newer firmware's) is an error.
    pub fn new(r: &MotorReport) -> Result<BoardReport> {
        let parameters = r
            .estimates
            .iter()
            .map(|e| {
                let id = ParamId::ALL
                    .get(usize::from(e.param))
                    .copied()
                    .ok_or_else(|| {
                        anyhow!("the board reports an unknown parameter (code {})", e.param)
                    })?;
                Ok((id, ParamEstimate::with_std(e.value, e.std)))
            })
            .collect::<Result<ByParam<ParamEstimate>>>()?;
        Ok(BoardReport {
            schema_version: crate::report::SCHEMA_VERSION,
            params: parameters.iter().map(|(id, e)| (*id, e.value)).collect(),
            rmse_omega: Num(r.rmse_omega),
            evaluations: r.evaluations,
            identifiability: BoardIdentifiability {
                rank: r.rank,
                free: parameters.0.len(),
                parameters,
            },
            unpinned: BTreeMap::new(),
        })
    }

    /// This report with the reasons of its unpinned parameters ([`unpinned_reasons`]),
    /// printed after the parameters and written to the JSON.
    pub fn with_unpinned(mut self, unpinned: BTreeMap<&'static str, String>) -> BoardReport {
        self.unpinned = unpinned;
        self
    }

    /// The text printed on stdout.
    pub fn text(&self) -> String {
        let mut s = String::new();
        for (id, e) in self.identifiability.parameters.iter() {
            let std = match e.std {
                Some(Num(std)) if e.pinned => format!("+- {std:.3e}"),
                _ => "NOT pinned".into(),
            };
            s += &format!("  {:<3} = {:<14} {std}\n", id.name(), e.value.0);
        }
        s += &format!(
            "rmse_omega = {} rad/s, {} evaluations, rank {}\n",
            self.rmse_omega.0, self.evaluations, self.identifiability.rank
        );
        s += &unpinned_text(&self.unpinned);
        s
    }
}

/// Why each parameter of `r` that is not pinned is not pinned, by name, from the
/// commissioning's `plan` and one count of the current reading `current_count` [A] (0 when
/// it is not known: no parameter is then said to be below the resolution).
pub fn unpinned_reasons(
    r: &MotorReport,
    plan: &Plan,
    current_count: f32,
) -> BTreeMap<&'static str, String> {
    r.estimates
        .iter()
        .filter(|e| !e.pinned())
        .filter_map(|e| ParamId::ALL.get(usize::from(e.param)))
        .map(|&id| {
            (
                id.name(),
                why_not_pinned(id, r, plan, current_count).to_string(),
            )
        })
        .collect()
}

/// One line per unpinned parameter: `NAME not pinned: WHY`.
pub fn unpinned_text(unpinned: &BTreeMap<&'static str, String>) -> String {
    unpinned
        .iter()
        .map(|(name, why)| format!("{name} not pinned: {why}\n"))
        .collect()
}

/// The plan of a commissioning in a few lines: what the probe measured, the experiment
/// designed from it.
pub fn plan_text(p: &Plan) -> String {
    let breakaway = match p.breakaway_volts {
        v if v.is_finite() => format!("break-away at {v:.3} V"),
        _ => "no break-away before the calibration current".into(),
    };
    format!(
        "probe ({:.1} s): current offset {:.4} A, {breakaway}, Ra ~ {:.4} ohm, La/Ra ~ {:.3e} s, Kv ~ {:.4} V s/rad (the back-EMF taking {:.3e} A), mechanical time ~ {:.3} s\n\
         experiment: {:.2} V; slow record {} samples of {:.3e} s, fast record {} samples of {:.3e} s; {:.1} s in all",
        p.probe_seconds,
        p.current_offset,
        p.ra,
        p.tau_e,
        p.kv,
        p.back_emf_current,
        p.tau_m,
        p.volts,
        p.slow_samples,
        p.slow_dt,
        p.fast_samples,
        p.fast_dt,
        p.planned_seconds,
    )
}
