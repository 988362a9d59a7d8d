//! The `identify` report: JSON (DESIGN.md contract: `params`, `rmse_omega`, `evaluations`,
//! `identifiability`, plus more fields) and the text summary printed on stdout.

use motor_id_shared::fit::identifiability::Identifiability;
use motor_id_shared::fit::identify::Identification;
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::ParamId;
use serde_json::{json, Map, Value};

/// An f32 as the shortest decimal that reads back to it; `null` when not finite.
pub fn num(x: f32) -> Value {
    if x.is_finite() {
        let shortest: f64 = x.to_string().parse().unwrap_or(x as f64);
        json!(shortest)
    } else {
        Value::Null
    }
}

/// Parameters reported: the five motor ones, and every effect parameter that is free or
/// non-zero (an effect that is part of the model).
pub fn params_json(id: &Identification, spec: &ProblemSpec) -> Value {
    let mut m = Map::new();
    for p in ParamId::ALL {
        let v = id.params.get(p);
        let shown = p.is_motor()
            || spec.free[p.index()]
            || (v != 0.0 && p != ParamId::RippleCycles)
            || (p == ParamId::RippleCycles && id.params.get(ParamId::RippleAmp) != 0.0);
        if shown {
            m.insert(p.name().into(), num(v));
        }
    }
    Value::Object(m)
}

/// Which quantities are pinned, with uncertainty, and the flat directions.
pub fn identifiability_json(ident: &Identifiability) -> Value {
    let mut parameters = Map::new();
    for p in &ident.params {
        parameters.insert(
            p.id.name().into(),
            json!({
                "value": num(p.value),
                "pinned": p.pinned,
                "std": p.std.map_or(Value::Null, num),
            }),
        );
    }
    let combinations: Vec<Value> = ident
        .combinations
        .iter()
        .map(|c| {
            json!({
                "name": c.combination.name(),
                "value": num(c.value),
                "pinned": c.pinned,
                "rel_std": c.rel_std.map_or(Value::Null, num),
            })
        })
        .collect();
    let directions: Vec<Value> = ident
        .unpinned
        .iter()
        .map(|d| {
            let mut comps = Map::new();
            for (p, c) in ident.params.iter().zip(d.components.iter()) {
                if c.abs() >= 0.005 {
                    comps.insert(p.id.name().into(), num((c * 1000.0).round() / 1000.0));
                }
            }
            json!({ "components": comps, "std": num(d.std) })
        })
        .collect();
    let pinned: Vec<&str> = ident
        .params
        .iter()
        .filter(|p| p.pinned)
        .map(|p| p.id.name())
        .chain(
            ident
                .combinations
                .iter()
                .filter(|c| c.pinned)
                .map(|c| c.combination.name()),
        )
        .collect();
    let not_pinned: Vec<&str> = ident
        .params
        .iter()
        .filter(|p| !p.pinned)
        .map(|p| p.id.name())
        .chain(
            ident
                .combinations
                .iter()
                .filter(|c| !c.pinned)
                .map(|c| c.combination.name()),
        )
        .collect();
    json!({
        "rank": ident.rank,
        "free": ident.params.len(),
        "all_pinned": ident.all_pinned(),
        "pinned": pinned,
        "not_pinned": not_pinned,
        "parameters": parameters,
        "combinations": combinations,
        "unpinned_directions": directions,
        "note": "directions are in natural coordinates: ln(p) for log-scaled parameters; std is one standard deviation there",
    })
}

/// The whole `identify` JSON report.
pub fn identify_json(
    id: &Identification,
    spec: &ProblemSpec,
    files: &[String],
    seed: u64,
    mode: &str,
) -> Value {
    let trace: Vec<Value> = id
        .trace
        .iter()
        .map(|t| json!({ "evaluations": t.evaluations, "best": num(t.best) }))
        .collect();
    json!({
        "params": params_json(id, spec),
        "rmse_omega": num(id.cost.rmse_omega),
        "rmse_current": id.cost.rmse_current.map_or(Value::Null, num),
        "evaluations": id.evaluations,
        "analysis_evaluations": id.analysis_evaluations,
        "identifiability": identifiability_json(&id.identifiability),
        "noise": {
            "sigma_omega": num(id.sigma_omega),
            "sigma_current": id.sigma_current.map_or(Value::Null, num),
        },
        "fitness": num(id.cost.fitness()),
        "fit_quality": {
            "rmse_over_noise": num(id.cost.rmse_omega / id.sigma_omega),
            "model_adequate": id.cost.rmse_omega / id.sigma_omega <= MISFIT_RATIO,
        },
        "completed": id.completed,
        "convergence": trace,
        "records": files,
        "seed": seed,
        "mode": mode,
    })
}

/// RMSE above this multiple of the measured noise means the model misfits the data.
const MISFIT_RATIO: f32 = 1.5;

/// Six significant digits, scientific notation for very small or large magnitudes.
fn sig(x: f32) -> String {
    let a = x.abs();
    if x == 0.0 {
        return "0".into();
    }
    if (1e-3..1e6).contains(&a) {
        let decimals = (5 - a.log10().floor().max(-3.0) as i32).clamp(0, 8) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.5e}")
    }
}

fn unit(p: ParamId) -> &'static str {
    match p {
        ParamId::Ra => "ohm",
        ParamId::La => "H",
        ParamId::J => "kg m^2",
        ParamId::B => "N m s/rad",
        ParamId::Kv => "V s/rad",
        ParamId::Tc => "N m",
        ParamId::Kq => "N m s^2/rad^2",
        ParamId::Kar => "1/A",
        ParamId::Vb => "V",
        ParamId::Td => "s",
        ParamId::RipplePhase => "rad",
        ParamId::RippleAmp | ParamId::RippleCycles => "",
    }
}

/// Human-readable summary.
pub fn summary(
    id: &Identification,
    spec: &ProblemSpec,
    samples: usize,
    with_current: bool,
) -> String {
    let mut s = String::new();
    let ident = &id.identifiability;
    s += &format!(
        "fitted {samples} samples ({}), {} evaluations{}\n",
        if with_current {
            "speed and current"
        } else {
            "speed only"
        },
        id.evaluations,
        if id.completed { "" } else { " (stopped early)" }
    );
    for p in ParamId::ALL {
        let free = ident.params.iter().find(|c| c.id == p);
        let v = id.params.get(p);
        let status = match free {
            Some(c) if c.pinned => match c.std {
                Some(sd) => format!("+- {:.3} %", 100.0 * sd / v.abs().max(f32::MIN_POSITIVE)),
                None => "pinned".into(),
            },
            Some(_) => "NOT pinned by this data".into(),
            None if spec.free[p.index()] => String::new(),
            None if p.is_motor() || v != 0.0 && p != ParamId::RippleCycles => "fixed".into(),
            None => continue,
        };
        s += &format!(
            "  {:<13} = {:<12} {:<14} {}\n",
            p.name(),
            sig(v),
            unit(p),
            status
        );
    }
    s += &format!(
        "rmse_omega = {:.6} rad/s (measured noise {:.6} rad/s)",
        id.cost.rmse_omega, id.sigma_omega
    );
    if let Some(rc) = id.cost.rmse_current {
        s += &format!(", rmse_current = {rc:.6} A");
    }
    s += "\n";
    let ratio = id.cost.rmse_omega / id.sigma_omega;
    if ratio > MISFIT_RATIO {
        s += &format!(
            "warning: the fit is {ratio:.1} x the measured noise: the model misses something in \
             this data (an unmodelled effect?); the uncertainties below assume white residuals \
             and are optimistic\n"
        );
    }
    s += &format!(
        "identifiability: the data pins {} of {} directions\n",
        ident.rank,
        ident.params.len()
    );
    for c in &ident.combinations {
        if c.pinned {
            s += &format!(
                "  pinned     {:<20} = {:<12} +- {:.3} %\n",
                c.combination.name(),
                sig(c.value),
                100.0 * c.rel_std.unwrap_or(f32::NAN)
            );
        }
    }
    for d in &ident.unpinned {
        let terms: Vec<String> = ident
            .params
            .iter()
            .zip(d.components.iter())
            .filter(|(_, c)| c.abs() >= 0.05)
            .map(|(p, c)| format!("{c:+.2} {}", p.id.name()))
            .collect();
        s += &format!("  flat along {} (log scale)\n", terms.join(" "));
    }
    if !ident.all_pinned() {
        s += "  parameters marked NOT pinned fit the data equally well over a range: add the armature \
              current (column i), a known load-torque step (column tl), or fix what was measured \
              otherwise (--fix ra=...)\n";
    }
    s
}

#[cfg(test)]
mod tests {
    use super::sig;

    #[test]
    fn significant_digits() {
        assert_eq!(sig(3.412), "3.41200");
        assert_eq!(sig(0.0573), "0.0573000");
        assert_eq!(sig(1.3e-5), "1.30000e-5");
        assert_eq!(sig(0.0), "0");
        assert_eq!(sig(1234.5), "1234.50");
    }
}
