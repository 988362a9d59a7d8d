//! `motor-id diagnose`: where the model misfits, which unmodelled effect causes it, how far
//! the misfit shrinks once it is modelled — judged on held-out records the fit never saw.

mod regimes;
mod verdict;

use crate::csvio::OwnedRecord;
use crate::fit::{fit_from, Fit, FitOptions};
use crate::output::write_json;
use crate::plot::{draw, Panel, Series};
use crate::report::num;
use anyhow::{anyhow, bail, Result};
use clap::Args;
use motor_id_shared::effects::{Effect, Scales};
use motor_id_shared::objective::Objective;
use motor_id_shared::space::ProblemSpec;
use motor_id_shared::{ModelParams, ParamId, Record};
use plotters::style::{RGBColor, BLUE, RED};
use regimes::Trace;
use serde_json::{json, Map, Value};
use std::path::PathBuf;
use verdict::{significant, Candidate, Holdout};

/// Arguments of `diagnose`.
#[derive(Args, Debug)]
pub struct DiagnoseArgs {
    /// Records to fit on.
    #[arg(long, required = true, num_args = 1..)]
    pub train: Vec<PathBuf>,
    /// Records the fits never see, to judge them on.
    #[arg(long, required = true, num_args = 1..)]
    pub holdout: Vec<PathBuf>,
    #[command(flatten)]
    pub fit: FitOptions,
    /// Write the JSON report here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write a PNG plot (measured vs baseline vs with-effect speed, residuals, misfit by
    /// regime) here.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// One fitted model and how it does on both sets.
struct Scored {
    fit: Fit,
    train_rmse: f32,
    holdout_rmse: f32,
}

struct Data {
    train: Vec<OwnedRecord>,
    holdout: Vec<OwnedRecord>,
    with_current: bool,
}

impl Data {
    fn holdout_rmse(&self, p: &ModelParams) -> Result<f32> {
        let recs: Vec<Record> = self
            .holdout
            .iter()
            .map(|r| r.as_record(self.with_current))
            .collect();
        let obj = Objective::new(&recs).map_err(|e| anyhow!("holdout: {e}"))?;
        obj.cost(p)
            .map(|c| c.rmse_omega)
            .ok_or_else(|| anyhow!("holdout records cannot be simulated with the fitted model"))
    }

    fn holdout_rms(&self) -> f32 {
        let (sum, n) = self
            .holdout
            .iter()
            .flat_map(|r| r.omega.iter())
            .fold((0.0f64, 0usize), |(s, n), w| {
                (s + (*w as f64) * (*w as f64), n + 1)
            });
        (sum / n.max(1) as f64).sqrt() as f32
    }

    fn holdout_noise(&self) -> Result<f32> {
        let recs: Vec<Record> = self
            .holdout
            .iter()
            .map(|r| r.as_record(self.with_current))
            .collect();
        Ok(Objective::new(&recs)
            .map_err(|e| anyhow!("holdout: {e}"))?
            .sigma_omega())
    }

    fn scales(&self, p: &ModelParams) -> Scales {
        let all = self.train.iter().chain(&self.holdout);
        let peak = |x: &[f32]| x.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        let v_max = all.clone().map(|r| peak(&r.v)).fold(0.0, f32::max);
        let omega_max = all.clone().map(|r| peak(&r.omega)).fold(0.0, f32::max);
        let measured = all
            .clone()
            .filter_map(|r| r.current.as_deref().map(peak))
            .fold(0.0, f32::max);
        let current_max = if measured > 0.0 {
            measured
        } else {
            v_max / p.get(ParamId::Ra)
        };
        let dt = all.map(|r| r.dt).fold(f32::INFINITY, f32::min);
        Scales {
            v_max,
            omega_max,
            current_max,
            dt,
        }
    }

    fn score(&self, fit: Fit) -> Result<Scored> {
        let holdout_rmse = self.holdout_rmse(&fit.result.params)?;
        Ok(Scored {
            train_rmse: fit.result.cost.rmse_omega,
            holdout_rmse,
            fit,
        })
    }
}

/// `spec` with `effect` free within bounds scaled to `base` (user bounds or fixes on its
/// parameters are kept); for the tacho ripple the number of cycles is the order found in the
/// residual, held fixed (the phase and amplitude are fitted).
fn with_effect(
    spec: &ProblemSpec,
    effect: Effect,
    base: &ModelParams,
    scales: &Scales,
    order: u32,
) -> Result<ProblemSpec> {
    let mut s = *spec;
    s.base = *base;
    for (id, lo, hi) in effect.bounds(base, scales) {
        if id == ParamId::RippleCycles {
            if spec.free[id.index()] {
                continue;
            }
            s.fix(id, order as f32).map_err(|e| anyhow!("{e}"))?;
            continue;
        }
        let user_fixed = !spec.free[id.index()] && spec.base.get(id) != 0.0;
        if user_fixed || spec.free[id.index()] {
            continue;
        }
        s.set_bounds(id, lo, hi)
            .map_err(|e| anyhow!("{} bounds: {e}", effect.name()))?;
        s.free(id);
    }
    Ok(s)
}

fn params_json(p: &ModelParams, ids: &[ParamId]) -> Value {
    let mut m = Map::new();
    for id in ids {
        m.insert(id.name().into(), num(p.get(*id)));
    }
    Value::Object(m)
}

/// Run `diagnose`.
pub fn run(a: &DiagnoseArgs) -> Result<()> {
    let load = |files: &[PathBuf]| -> Result<Vec<OwnedRecord>> {
        files.iter().map(|f| OwnedRecord::read(f)).collect()
    };
    let train = load(&a.train)?;
    let holdout = load(&a.holdout)?;
    let with_current =
        !a.fit.speed_only && train.iter().chain(&holdout).all(|r| r.current.is_some());
    let data = Data {
        train,
        holdout,
        with_current,
    };
    let say = |msg: String| {
        if !a.fit.quiet {
            eprintln!("{msg}");
        }
    };
    let quiet = FitOptions {
        quiet: true,
        speed_only: !with_current,
        ..a.fit.clone()
    };
    let spec = crate::spec::problem(&a.fit.bounds, &a.fit.fix)?;
    say("fitting the baseline model on the training records".into());
    let baseline = data.score(fit_from(&data.train, &quiet, &spec, None)?)?;
    let base_params = baseline.fit.result.params;
    let noise = baseline.fit.result.sigma_omega;
    let holdout_noise = data.holdout_noise()?;
    let holdout = Holdout {
        noise: holdout_noise,
        signal_rms: data.holdout_rms(),
    };
    let traces = baseline_traces(&data, &base_params)?;
    let where_ = regimes::analyse(&traces, noise);
    let ripple = regimes::order_peak(&traces);
    let order = ripple.order;
    let scales = data.scales(&base_params);

    // Which: every effect of the catalogue, refitted on the training records.
    let mut scored: Vec<(Effect, Scored)> = Vec::new();
    for (k, effect) in Effect::ALL.iter().enumerate() {
        say(format!(
            "fitting with {} ({}/{})",
            effect.name(),
            k + 1,
            Effect::ALL.len()
        ));
        let s = with_effect(&spec, *effect, &base_params, &scales, order)?;
        let f = fit_effect(&data, &quiet, &s, *effect, &ripple)?;
        scored.push((*effect, data.score(f)?));
    }
    scored.sort_by(|a, b| a.1.holdout_rmse.total_cmp(&b.1.holdout_rmse));
    let reference = Candidate::of(&baseline.fit, baseline.holdout_rmse, 0);
    let first = scored
        .iter()
        .filter(|(e, s)| significant(&reference, &candidate(*e, s, &scales), &holdout))
        .map(|(e, _)| *e)
        .next();

    // A second effect, on what is left after the first.
    let mut second: Option<(Effect, Scored)> = None;
    if let Some(e1) = first {
        let first_fit = &scored.iter().find(|(e, _)| *e == e1).expect("scored").1;
        let p1 = first_fit.fit.result.params;
        let spec1 = with_effect(&spec, e1, &base_params, &scales, order)?;
        let mut spec1 = spec1;
        spec1.base = p1;
        let reference1 = Candidate::of(&first_fit.fit, first_fit.holdout_rmse, 0);
        let mut best: Option<(Effect, Scored)> = None;
        for effect in Effect::ALL.iter().filter(|e| **e != e1) {
            say(format!("fitting {} on top of {}", effect.name(), e1.name()));
            let s = with_effect(&spec1, *effect, &p1, &scales, order)?;
            let f = data.score(fit_effect(&data, &quiet, &s, *effect, &ripple)?)?;
            if significant(&reference1, &candidate(*effect, &f, &scales), &holdout)
                && best
                    .as_ref()
                    .is_none_or(|(_, b)| f.holdout_rmse < b.holdout_rmse)
            {
                best = Some((*effect, f));
            }
        }
        second = best;
    }

    let report = build_report(
        &data,
        &scales,
        &holdout,
        &baseline,
        &scored,
        first,
        second.as_ref(),
        where_,
        holdout_noise,
    );
    print!("{}", text_summary(&report));
    if let Some(path) = &a.json {
        write_json(path, &report)?;
    }
    if let Some(path) = &a.plot {
        let chosen = first
            .and_then(|e| scored.iter().find(|(x, _)| *x == e))
            .map(|(_, s)| &s.fit.result.params);
        plot(path, &data, &base_params, chosen, &report)?;
    }
    Ok(())
}

/// Fit `spec` (an effect added to the model in `spec.base`) in two stages: the effect's
/// parameters alone with everything else held at `base` (a search of one to three
/// dimensions, started for the ripple from the order spectrum's amplitude and phase), then
/// everything free from there.
fn fit_effect(
    data: &Data,
    opts: &FitOptions,
    spec: &ProblemSpec,
    effect: Effect,
    ripple: &regimes::OrderPeak,
) -> Result<Fit> {
    // The spec's base holds the model to add the effect to, and the effect's fixed values.
    let mut start = spec.base;
    if effect == Effect::TachoRipple {
        let (lo, hi) = spec.bounds[ParamId::RippleAmp.index()];
        start.set(ParamId::RippleAmp, (ripple.amp as f32).clamp(lo, hi));
        start.set(ParamId::RipplePhase, ripple.phase as f32);
    }
    let mut alone = *spec;
    alone.base = start;
    for id in ParamId::ALL {
        if !effect.params().contains(&id) && alone.free[id.index()] {
            alone.free[id.index()] = false;
        }
    }
    let first = fit_from(&data.train, opts, &alone, Some(&start))?;
    fit_from(&data.train, opts, spec, Some(&first.result.params))
}

/// The significance rule's view of an effect fit: a tacho delay under half a sample is below
/// what the sampling resolves (see [`verdict`]).
fn candidate(effect: Effect, s: &Scored, scales: &Scales) -> Candidate {
    let too_short =
        effect == Effect::SensorDelay && s.fit.result.params.get(ParamId::Td) < 0.5 * scales.dt;
    Candidate::of(&s.fit, s.holdout_rmse, effect.params().len()).unresolvable(too_short)
}

/// Baseline residual traces of every record (train and holdout).
fn baseline_traces(data: &Data, p: &ModelParams) -> Result<Vec<Trace>> {
    let mut out = Vec::new();
    for (set, recs) in [("train", &data.train), ("holdout", &data.holdout)] {
        let borrowed: Vec<Record> = recs
            .iter()
            .map(|r| r.as_record(data.with_current))
            .collect();
        let obj = Objective::new(&borrowed).map_err(|e| anyhow!("{e}"))?;
        for (k, r) in recs.iter().enumerate() {
            let mut w = vec![0.0; r.len()];
            let mut i = vec![0.0; r.len()];
            obj.simulate(p, k, &mut w, &mut i)
                .map_err(|e| anyhow!("{e}"))?;
            let current = r.current.clone().unwrap_or(i);
            out.push(Trace {
                name: r.name(),
                set,
                dt: r.dt,
                residual: r.omega.iter().zip(&w).map(|(m, s)| m - s).collect(),
                omega: w,
                current,
            });
        }
    }
    Ok(out)
}

fn motor_shift(base: &ModelParams, after: &ModelParams) -> Value {
    let mut m = Map::new();
    for id in ParamId::MOTOR {
        m.insert(id.name().into(), num(after.get(id) / base.get(id) - 1.0));
    }
    Value::Object(m)
}

fn effect_std(s: &Scored, effect: Effect) -> Value {
    let mut m = Map::new();
    for c in s
        .fit
        .result
        .identifiability
        .params
        .iter()
        .filter(|c| effect.params().contains(&c.id))
    {
        m.insert(c.id.name().into(), c.std.map_or(Value::Null, num));
    }
    Value::Object(m)
}

#[allow(clippy::too_many_arguments)]
fn build_report(
    data: &Data,
    scales: &Scales,
    holdout: &Holdout,
    baseline: &Scored,
    scored: &[(Effect, Scored)],
    first: Option<Effect>,
    second: Option<&(Effect, Scored)>,
    where_: Value,
    holdout_noise: f32,
) -> Value {
    let base_params = &baseline.fit.result.params;
    let effects: Vec<Value> = scored
        .iter()
        .map(|(e, s)| {
            let mut params = Map::new();
            for id in ParamId::MOTOR.iter().chain(e.params()) {
                params.insert(id.name().into(), num(s.fit.result.params.get(*id)));
            }
            json!({
                "name": e.name(),
                "train_rmse": num(s.train_rmse),
                "holdout_rmse": num(s.holdout_rmse),
                "params": Value::Object(params),
                "effect_std": effect_std(s, *e),
                "significant": first == Some(*e) || significant(
                    &Candidate::of(&baseline.fit, baseline.holdout_rmse, 0),
                    &candidate(*e, s, scales),
                    holdout,
                ),
            })
        })
        .collect();
    let chosen = first.and_then(|e| scored.iter().find(|(x, _)| *x == e));
    let after = chosen.map_or(baseline.holdout_rmse, |(_, s)| s.holdout_rmse);
    let removed = {
        let (b2, a2, n2) = (
            baseline.holdout_rmse.powi(2),
            after.powi(2),
            holdout_noise.powi(2),
        );
        let excess = (b2 - n2).max(f32::MIN_POSITIVE);
        ((b2 - a2) / excess).clamp(0.0, 1.0)
    };
    let mut verdict = json!({
        "effect": first.map(|e| e.name()),
        "holdout_rmse_before": num(baseline.holdout_rmse),
        "holdout_rmse_after": num(after),
        "train_rmse_before": num(baseline.train_rmse),
        "train_rmse_after": num(chosen.map_or(baseline.train_rmse, |(_, s)| s.train_rmse)),
        "share_of_misfit_removed": num(removed),
        "holdout_noise": num(holdout_noise),
    });
    if let Some((e, s)) = chosen {
        verdict["effect_params"] = params_json(&s.fit.result.params, e.params());
        verdict["effect_std"] = effect_std(s, *e);
        verdict["base_params_shift"] = motor_shift(base_params, &s.fit.result.params);
    }
    verdict["second"] = match second {
        Some((e, s)) => json!({
            "effect": e.name(),
            "holdout_rmse_after": num(s.holdout_rmse),
            "train_rmse_after": num(s.train_rmse),
            "effect_params": params_json(&s.fit.result.params, e.params()),
        }),
        None => json!({ "effect": Value::Null }),
    };
    let cannot = cannot_support(data, baseline, chosen);
    json!({
        "baseline": {
            "train_rmse": num(baseline.train_rmse),
            "holdout_rmse": num(baseline.holdout_rmse),
            "params": crate::report::params_json(&baseline.fit.result, &baseline.fit.spec),
            "noise_train": num(baseline.fit.result.sigma_omega),
            "noise_holdout": num(holdout_noise),
        },
        "effects": effects,
        "verdict": verdict,
        "where": where_,
        "data": {
            "current": data.with_current,
            "train": data.train.iter().map(|r| r.name()).collect::<Vec<_>>(),
            "holdout": data.holdout.iter().map(|r| r.name()).collect::<Vec<_>>(),
        },
        "cannot_support": cannot,
    })
}

/// Conclusions the data cannot support (identifiability).
fn cannot_support(
    data: &Data,
    baseline: &Scored,
    chosen: Option<&(Effect, Scored)>,
) -> Vec<String> {
    let mut out = Vec::new();
    let unpinned = |s: &Scored| -> Vec<&'static str> {
        s.fit
            .result
            .identifiability
            .params
            .iter()
            .filter(|c| !c.pinned)
            .map(|c| c.id.name())
            .collect()
    };
    let base = unpinned(baseline);
    if !base.is_empty() {
        out.push(format!(
            "the baseline does not pin {}: how they move when an effect is added says nothing",
            base.join(", ")
        ));
    }
    if !data.with_current {
        out.push(
            "no current was measured: brush_drop and armature_reaction act through the current, so \
             they are told apart from each other and from Ra, Kv only by the speed trace"
                .into(),
        );
    }
    let has_load = |recs: &[OwnedRecord]| recs.iter().any(|r| r.load.is_some());
    if !data.with_current && has_load(&data.holdout) && !has_load(&data.train) && !base.is_empty() {
        out.push(
            "the held-out records have a known load torque, whose effect on speed the training \
             records (speed only, voltage only) do not pin: their RMSE judges the unpinned \
             parameters as much as any effect"
                .into(),
        );
    }
    if let Some((e, s)) = chosen {
        let not: Vec<&str> = unpinned(s)
            .into_iter()
            .filter(|n| e.params().iter().any(|p| p.name() == *n))
            .collect();
        if !not.is_empty() {
            out.push(format!(
                "{} improves the fit, but its parameter(s) {} are not pinned",
                e.name(),
                not.join(", ")
            ));
        }
    }
    out
}

fn text_summary(r: &Value) -> String {
    let mut s = String::new();
    let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
    s += &format!(
        "baseline: train rmse {:.4}, holdout rmse {:.4} rad/s (holdout noise {:.4})\n",
        f(&r["baseline"]["train_rmse"]),
        f(&r["baseline"]["holdout_rmse"]),
        f(&r["verdict"]["holdout_noise"])
    );
    s += "where:\n";
    for line in r["where"]["summary"].as_array().into_iter().flatten() {
        s += &format!("  {}\n", line.as_str().unwrap_or(""));
    }
    s += "effects, best held-out rmse first:\n";
    for e in r["effects"].as_array().into_iter().flatten() {
        s += &format!(
            "  {:<18} train {:.4}  holdout {:.4}{}\n",
            e["name"].as_str().unwrap_or(""),
            f(&e["train_rmse"]),
            f(&e["holdout_rmse"]),
            if e["significant"] == true {
                "  significant"
            } else {
                ""
            }
        );
    }
    let v = &r["verdict"];
    match v["effect"].as_str() {
        Some(name) => {
            s += &format!(
                "verdict: {name}: holdout rmse {:.4} -> {:.4} rad/s ({:.0} % of the misfit above noise removed), params {}\n",
                f(&v["holdout_rmse_before"]),
                f(&v["holdout_rmse_after"]),
                100.0 * f(&v["share_of_misfit_removed"]),
                v["effect_params"]
            );
            if let Some(second) = v["second"]["effect"].as_str() {
                s += &format!(
                    "then: {second}: holdout rmse -> {:.4} rad/s\n",
                    f(&v["second"]["holdout_rmse_after"])
                );
            }
        }
        None => s +=
            "verdict: null (no effect of the catalogue improves the held-out fit significantly)\n",
    }
    for c in r["cannot_support"].as_array().into_iter().flatten() {
        s += &format!("note: {}\n", c.as_str().unwrap_or(""));
    }
    s
}

fn plot(
    path: &std::path::Path,
    data: &Data,
    base: &ModelParams,
    chosen: Option<&ModelParams>,
    report: &Value,
) -> Result<()> {
    let recs: Vec<Record> = data
        .holdout
        .iter()
        .map(|r| r.as_record(data.with_current))
        .collect();
    let obj = Objective::new(&recs).map_err(|e| anyhow!("{e}"))?;
    let (mut t, mut meas, mut wb, mut we, mut rb, mut re) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    let mut offset = 0.0;
    for (k, r) in data.holdout.iter().enumerate() {
        let n = r.len();
        let (mut b, mut e, mut i) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        obj.simulate(base, k, &mut b, &mut i)
            .map_err(|e| anyhow!("{e}"))?;
        obj.simulate(chosen.unwrap_or(base), k, &mut e, &mut i)
            .map_err(|e| anyhow!("{e}"))?;
        for s in 0..n {
            t.push(offset + s as f64 * r.dt as f64);
            meas.push(r.omega[s]);
            wb.push(b[s]);
            we.push(e[s]);
            rb.push(r.omega[s] - b[s]);
            re.push(r.omega[s] - e[s]);
        }
        offset += n as f64 * r.dt as f64;
    }
    let regimes = report["where"]["regimes"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let labels: Vec<String> = regimes
        .iter()
        .map(|r| r["short"].as_str().unwrap_or("").to_string())
        .collect();
    let share: Vec<f32> = regimes
        .iter()
        .map(|r| r["share_of_misfit"].as_f64().unwrap_or(0.0) as f32)
        .collect();
    let samples: Vec<f32> = regimes
        .iter()
        .map(|r| r["share_of_samples"].as_f64().unwrap_or(0.0) as f32)
        .collect();
    let label = report["verdict"]["effect"]
        .as_str()
        .unwrap_or("no effect")
        .to_string();
    let green = RGBColor(0, 140, 0);
    let panels = [
        Panel {
            title: "held-out speed: measured, baseline, with the verdict's effect".into(),
            x_label: "t [s] (held-out records side by side)",
            y_label: "omega [rad/s]",
            series: vec![
                Series {
                    label: "measured",
                    x: &t,
                    y: &meas,
                    color: BLUE,
                },
                Series {
                    label: "baseline",
                    x: &t,
                    y: &wb,
                    color: RED,
                },
                Series {
                    label: &label,
                    x: &t,
                    y: &we,
                    color: green,
                },
            ],
            log_y: false,
            categories: None,
        },
        Panel {
            title: "held-out residual before / after".into(),
            x_label: "t [s]",
            y_label: "omega error [rad/s]",
            series: vec![
                Series {
                    label: "baseline",
                    x: &t,
                    y: &rb,
                    color: RED,
                },
                Series {
                    label: &label,
                    x: &t,
                    y: &re,
                    color: green,
                },
            ],
            log_y: false,
            categories: None,
        },
        Panel {
            title: "baseline misfit by regime (train and held-out records)".into(),
            x_label: "regime",
            y_label: "share",
            series: vec![
                Series {
                    label: "share of misfit",
                    x: &[],
                    y: &share,
                    color: RED,
                },
                Series {
                    label: "share of samples",
                    x: &[],
                    y: &samples,
                    color: BLUE,
                },
            ],
            log_y: false,
            categories: Some(labels),
        },
    ];
    if regimes.is_empty() {
        bail!("no regime to plot");
    }
    draw(path, &panels)
}
