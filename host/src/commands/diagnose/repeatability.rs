//! The repeatability floor: how far repeat runs of one experiment differ from each other.
//! Measurement noise is not the only part of a residual no model can remove: a motor run
//! twice with the same voltage does not give the same speed twice (friction that depends on
//! the rotor angle and the temperature, where the brushes sit, the encoder's phase at the
//! start). A deterministic model can at best predict the runs' common response, so its
//! held-out RMSE cannot go below the run-to-run spread.
//!
//! **Estimate.** Runs `y_1 .. y_n` of one experiment are `y_k = m + e_k`, with `m` the common
//! response and the deviations `e_k` independent from run to run with the same spread `σ`
//! (each may be correlated in time). The deviation of run `k` from the mean of the others,
//! `d_k = y_k - (1/(n-1)) Σ_{j≠k} y_j = e_k - (1/(n-1)) Σ_{j≠k} e_j`, has
//! `E[d_k²] = σ² (1 + 1/(n-1)) = σ² n/(n-1)`, so run `k`'s floor is
//! `σ_k = sqrt((n-1)/n) · RMS(d_k)` (for two runs `|y_1 - y_2| / √2`); white noise alone
//! gives back its sigma. A group's floor is the RMS of its runs' floors, which is the pooled
//! standard deviation across runs `sqrt(Σ_k Σ_t (y_k - ȳ)² / ((n-1) N))`.
//!
//! **Repeats** are the runs named together by `--repeats`, and the records that agree as
//! inputs: the same sample step, lengths within [`LENGTH_SLACK`] samples, voltage (and known
//! load) sequences from the first sample equal within [`INPUT_TOLERANCE`] of their RMS. Runs
//! are compared sample by sample over their common length.

use super::data::Data;
use crate::csvio::{OwnedRecord, RecordReader};
use crate::report::Num;
use anyhow::{bail, Result};
use motor_id_shared::ModelParams;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Largest difference of length between repeats [samples].
const LENGTH_SLACK: usize = 5;
/// Largest RMS difference of the inputs relative to their RMS.
const INPUT_TOLERANCE: f64 = 0.02;
/// Largest relative difference of the sample steps.
const DT_TOLERANCE: f32 = 1e-4;
/// A remainder up to this multiple of the floor is the motor not repeating itself: the floor
/// is estimated from few runs whose deviations are correlated in time, so it is known to
/// about 10 %.
const WITHIN: f64 = 1.1;

/// How the floor is estimated (the report's `method`).
const METHOD: &str = "per run: RMS of its speed minus the mean speed of the other runs of its \
     group, times sqrt((n-1)/n) for n runs (one run's deviation from the common response; white \
     noise gives back its sigma); a group's floor is the RMS of its runs' floors. Repeats: named \
     together by --repeats, or detected (same dt, lengths within 5 samples, voltage and load \
     sequences from the first sample equal within 2 % of their RMS)";

/// The repeatability report.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct Repeatability {
    /// Groups of repeat runs.
    pub groups: Vec<Group>,
    /// How the floor is estimated.
    pub method: &'static str,
    /// The held-out records that have repeats, and the remainder against their floor.
    pub holdout: Option<HoldoutFloor>,
}

/// Repeat runs of one experiment.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct Group {
    /// The runs' files.
    pub records: Vec<String>,
    /// RMS of the runs' floors [rad/s].
    pub floor_rad_s: Num,
    /// `given` (by `--repeats`) or `detected`.
    pub found: &'static str,
    /// Each run.
    pub runs: Vec<RunFloor>,
}

/// One run of a group.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct RunFloor {
    /// File.
    pub file: String,
    /// `train`, `holdout` or `repeat` (given only by `--repeats`).
    pub set: &'static str,
    /// RMS of its speed minus the mean speed of the other runs [rad/s].
    pub vs_others_rms_rad_s: Num,
    /// Its deviation from the common response, `sqrt((n-1)/n)` times the above [rad/s].
    pub floor_rad_s: Num,
}

/// The held-out records with repeats: their floor and the remainder of the verdict's model.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct HoldoutFloor {
    /// The held-out files that have repeats.
    pub records: Vec<String>,
    /// RMS of their floors [rad/s].
    pub floor_rad_s: Num,
    /// Speed RMSE of the verdict's model on them [rad/s].
    pub remainder_rad_s: Num,
    /// Whether the remainder is at most 1.1 × the floor.
    pub within_floor: bool,
}

impl Repeatability {
    /// The floor of the held-out records (`verdict.repeatability_floor`).
    pub fn holdout_floor(&self) -> Option<Num> {
        self.holdout.as_ref().map(|h| h.floor_rad_s)
    }

    /// The findings in words.
    pub fn summary(&self) -> Vec<String> {
        let mut out: Vec<String> = self
            .groups
            .iter()
            .map(|g| {
                format!(
                    "repeatability: {} repeat one experiment ({}): a run differs from their \
                     common response by {:.3} rad/s RMS",
                    g.records.join(", "),
                    g.found,
                    g.floor_rad_s.0
                )
            })
            .collect();
        if let Some(h) = &self.holdout {
            let (rem, floor) = (h.remainder_rad_s.0 as f64, h.floor_rad_s.0 as f64);
            out.push(if h.within_floor {
                format!(
                    "the held-out remainder {rem:.3} rad/s is within the repeatability floor \
                     {floor:.3} rad/s of {}: it is the motor not repeating itself, not an \
                     unexplained effect",
                    h.records.join(", ")
                )
            } else {
                format!(
                    "the held-out remainder {rem:.3} rad/s is above the repeatability floor \
                     {floor:.3} rad/s of {}: {:.3} rad/s of it (in quadrature) is a misfit a \
                     better model could remove",
                    h.records.join(", "),
                    (rem * rem - floor * floor).max(0.0).sqrt()
                )
            });
        }
        out
    }
}

/// One record taking part.
struct Run<'a> {
    rec: &'a OwnedRecord,
    set: &'static str,
    /// Its index among the held-out records.
    holdout: Option<usize>,
}

fn rms(x: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = x.fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    (s / n.max(1) as f64).sqrt()
}

/// Whether `a` and `b` are equal within [`INPUT_TOLERANCE`] of their RMS over their common
/// length (two all-zero sequences agree).
fn same_input(a: &[f32], b: &[f32]) -> bool {
    let n = a.len().min(b.len());
    let scale = rms(a[..n].iter().map(|&x| x as f64)).max(rms(b[..n].iter().map(|&x| x as f64)));
    let diff = rms(a[..n].iter().zip(&b[..n]).map(|(x, y)| (x - y) as f64));
    diff <= INPUT_TOLERANCE * scale
}

fn same_dt(a: &OwnedRecord, b: &OwnedRecord) -> bool {
    (a.dt - b.dt).abs() <= DT_TOLERANCE * a.dt.abs().max(b.dt.abs())
}

/// Whether `a` and `b` are runs of the same experiment (module doc).
fn repeats(a: &OwnedRecord, b: &OwnedRecord) -> bool {
    let load = match (&a.load, &b.load) {
        (None, None) => true,
        (Some(x), Some(y)) => same_input(x, y),
        _ => false,
    };
    same_dt(a, b)
        && a.len().abs_diff(b.len()) <= LENGTH_SLACK
        && a.v.iter().any(|&v| v != 0.0)
        && same_input(&a.v, &b.v)
        && load
}

/// Each run's deviation from the mean of the others, and its floor (module doc), over the
/// runs' common length [rad/s].
pub fn floors(runs: &[&[f32]]) -> Vec<(f64, f64)> {
    let n = runs.len();
    let len = runs.iter().map(|r| r.len()).min().unwrap_or(0);
    if n < 2 || len == 0 {
        return vec![(f64::NAN, f64::NAN); n];
    }
    let sum: Vec<f64> = (0..len)
        .map(|t| runs.iter().map(|r| r[t] as f64).sum())
        .collect();
    let others = (n - 1) as f64;
    let correction = (others / n as f64).sqrt();
    runs.iter()
        .map(|r| {
            let d = rms((0..len).map(|t| r[t] as f64 - (sum[t] - r[t] as f64) / others));
            (d, correction * d)
        })
        .collect()
}

/// Whether `a` and `b` name the same file.
fn same_file(a: &Path, b: &Path) -> bool {
    a == b || matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
}

/// RMS of `floors`, each weighted by its run's length.
fn pooled(floors: impl Iterator<Item = (f64, usize)>) -> f64 {
    let (s, n) = floors.fold((0.0, 0usize), |(s, n), (f, len)| {
        (s + f * f * len as f64, n + len)
    });
    (s / n.max(1) as f64).sqrt()
}

/// Groups of repeat runs as `(indices into runs, "given" or "detected")`: those `given`, then
/// those detected among the rest.
fn group(runs: &[Run], given: &[Vec<PathBuf>]) -> Result<Vec<(Vec<usize>, &'static str)>> {
    let mut taken = vec![false; runs.len()];
    let mut groups = Vec::new();
    for names in given {
        let mut members: Vec<usize> = Vec::new();
        for p in names {
            let k = runs
                .iter()
                .position(|r| same_file(&r.rec.path, p))
                .expect("every given file is read");
            if taken[k] {
                bail!("--repeats: {} is named in two groups", p.display());
            }
            if !members.contains(&k) {
                members.push(k);
            }
        }
        if members.len() < 2 {
            bail!("--repeats: a group needs two runs or more");
        }
        let first = runs[members[0]].rec;
        if let Some(&k) = members.iter().find(|&&k| !same_dt(first, runs[k].rec)) {
            bail!(
                "--repeats: {} and {} have different sample steps",
                first.name(),
                runs[k].rec.name()
            );
        }
        members.iter().for_each(|&k| taken[k] = true);
        groups.push((members, "given"));
    }
    for k in 0..runs.len() {
        if taken[k] {
            continue;
        }
        let members: Vec<usize> = (k..runs.len())
            .filter(|&j| !taken[j] && (j == k || repeats(runs[k].rec, runs[j].rec)))
            .collect();
        if members.len() >= 2 {
            members.iter().for_each(|&j| taken[j] = true);
            groups.push((members, "detected"));
        }
    }
    Ok(groups)
}

/// The repeat groups with their floors, before the held-out remainder is known.
pub struct Repeats {
    groups: Vec<Group>,
    /// Each held-out run with repeats: (index among the held-out records, floor, length).
    held: Vec<(usize, f64, usize)>,
}

impl Repeats {
    /// The repeat groups among the records of `data` and the groups `given` by `--repeats`
    /// (comma-separated files, read by `reader` when they are not among the records).
    pub fn find(data: &Data, given: &[String], reader: &mut RecordReader) -> Result<Repeats> {
        let given: Vec<Vec<PathBuf>> = given
            .iter()
            .map(|g| {
                g.split(',')
                    .filter(|p| !p.is_empty())
                    .map(PathBuf::from)
                    .collect()
            })
            .collect();
        let mut runs: Vec<Run> = Vec::new();
        runs.extend(data.train.iter().map(|rec| Run {
            rec,
            set: "train",
            holdout: None,
        }));
        runs.extend(data.holdout.iter().enumerate().map(|(k, rec)| Run {
            rec,
            set: "holdout",
            holdout: Some(k),
        }));
        let mut extra: Vec<OwnedRecord> = Vec::new();
        for p in given.iter().flatten() {
            let known = |r: &OwnedRecord| same_file(&r.path, p);
            if !runs.iter().any(|r| known(r.rec)) && !extra.iter().any(known) {
                extra.push(reader.read(p)?);
            }
        }
        runs.extend(extra.iter().map(|rec| Run {
            rec,
            set: "repeat",
            holdout: None,
        }));
        let mut groups = Vec::new();
        let mut held = Vec::new();
        for (members, found) in group(&runs, &given)? {
            let speeds: Vec<&[f32]> = members.iter().map(|&k| &runs[k].rec.omega[..]).collect();
            let len = speeds.iter().map(|s| s.len()).min().unwrap_or(0);
            let fl = floors(&speeds);
            for (&k, &(_, f)) in members.iter().zip(&fl) {
                if let Some(h) = runs[k].holdout {
                    held.push((h, f, len));
                }
            }
            groups.push(Group {
                records: members.iter().map(|&k| runs[k].rec.name()).collect(),
                floor_rad_s: Num(pooled(fl.iter().map(|&(_, f)| (f, len))) as f32),
                found,
                runs: members
                    .iter()
                    .zip(&fl)
                    .map(|(&k, &(d, f))| RunFloor {
                        file: runs[k].rec.name(),
                        set: runs[k].set,
                        vs_others_rms_rad_s: Num(d as f32),
                        floor_rad_s: Num(f as f32),
                    })
                    .collect(),
            });
        }
        held.sort_by_key(|h| h.0);
        Ok(Repeats { groups, held })
    }

    /// The run-to-run floor of the held-out records that have repeats, pooled (`None`
    /// when none has): what no model can remove there.
    pub fn holdout_floor(&self) -> Option<f64> {
        (!self.held.is_empty()).then(|| pooled(self.held.iter().map(|&(_, f, len)| (f, len))))
    }

    /// The report, with `after` the verdict's model for the held-out remainder.
    pub fn report(self, data: &Data, after: &ModelParams) -> Result<Repeatability> {
        let holdout = match self.holdout_floor() {
            None => None,
            Some(floor) => {
                let which: Vec<usize> = self.held.iter().map(|h| h.0).collect();
                let remainder = data.holdout_rmse_of(after, &which)? as f64;
                Some(HoldoutFloor {
                    records: which.iter().map(|&k| data.holdout[k].name()).collect(),
                    floor_rad_s: Num(floor as f32),
                    remainder_rad_s: Num(remainder as f32),
                    within_floor: remainder <= WITHIN * floor,
                })
            }
        };
        Ok(Repeatability {
            groups: self.groups,
            method: METHOD,
            holdout,
        })
    }
}

#[cfg(test)]
#[path = "repeatability_tests.rs"]
mod tests;
