//! Parsing of the parameter arguments: `--motor ra=..,la=..`, `--effect NAME:key=val,...`,
//! `--bounds ra=LO:HI,...` and `--fix ra=V,...`.

use anyhow::{anyhow, bail, Context, Result};
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::model::effects::Effect;
use motor_id_shared::{ModelParams, ParamId};

/// Split `a=1,b=2` into pairs; empty items are refused.
fn pairs(list: &str) -> Result<Vec<(&str, &str)>> {
    list.split(',')
        .map(|item| {
            let item = item.trim();
            item.split_once('=')
                .map(|(k, v)| (k.trim(), v.trim()))
                .filter(|(k, v)| !k.is_empty() && !v.is_empty())
                .ok_or_else(|| anyhow!("expected key=value, got '{item}'"))
        })
        .collect()
}

fn number(key: &str, text: &str) -> Result<f32> {
    let x: f32 = text
        .parse()
        .map_err(|_| anyhow!("{key}: '{text}' is not a number"))?;
    if !x.is_finite() {
        bail!("{key}: '{text}' is not a finite number");
    }
    Ok(x)
}

fn param(name: &str) -> Result<ParamId> {
    ParamId::from_name(name).ok_or_else(|| {
        let all: Vec<&str> = ParamId::ALL.iter().map(|p| p.name()).collect();
        anyhow!("unknown parameter '{name}' (known: {})", all.join(", "))
    })
}

/// `ra=..,la=..,j=..,b=..,kv=..`: all five motor parameters, nothing else.
pub fn parse_motor(text: &str) -> Result<ModelParams> {
    let mut p = ModelParams::SEED_MOTOR;
    let mut seen = [false; 5];
    for (k, v) in pairs(text).context("--motor")? {
        let id = param(k).context("--motor")?;
        if !id.is_motor() {
            bail!("--motor: '{k}' is an effect parameter; give it with --effect");
        }
        let x = number(k, v).context("--motor")?;
        let ok = if id == ParamId::B { x >= 0.0 } else { x > 0.0 };
        if !ok {
            bail!(
                "--motor: {k} must be {}",
                if id == ParamId::B { ">= 0" } else { "> 0" }
            );
        }
        p.set(id, x);
        seen[id.index()] = true;
    }
    if let Some(missing) = ParamId::MOTOR.iter().find(|id| !seen[id.index()]) {
        bail!(
            "--motor: missing {} (give ra, la, j, b and kv)",
            missing.name()
        );
    }
    Ok(p)
}

/// `NAME:key=val,...` adds one effect to `p`.
pub fn apply_effect(p: &mut ModelParams, text: &str) -> Result<Effect> {
    let (name, rest) = text.split_once(':').unwrap_or((text, ""));
    let effect = Effect::from_name(name.trim()).ok_or_else(|| {
        let all: Vec<&str> = Effect::ALL.iter().map(|e| e.name()).collect();
        anyhow!(
            "--effect: unknown effect '{name}' (known: {})",
            all.join(", ")
        )
    })?;
    if rest.trim().is_empty() {
        let keys: Vec<&str> = effect.params().iter().map(|id| id.short_key()).collect();
        bail!(
            "--effect {name}: give its parameters, e.g. {name}:{}=...",
            keys.join("=...,")
        );
    }
    for (k, v) in pairs(rest).with_context(|| format!("--effect {name}"))? {
        let id = effect
            .params()
            .iter()
            .copied()
            .find(|id| id.short_key() == k || id.name() == k)
            .ok_or_else(|| {
                let keys: Vec<&str> = effect.params().iter().map(|id| id.short_key()).collect();
                anyhow!(
                    "--effect {name}: unknown key '{k}' (known: {})",
                    keys.join(", ")
                )
            })?;
        let x = number(k, v).with_context(|| format!("--effect {name}"))?;
        let (lo, hi) = id.physical_range();
        if x < lo || x > hi {
            bail!("--effect {name}: {k} = {x} is outside [{lo}, {hi}]");
        }
        p.set(id, x);
    }
    p.validate().map_err(|e| anyhow!("--effect {name}: {e}"))?;
    Ok(effect)
}

/// Apply `--bounds` and `--fix` to the default problem (seed Table 1, motor free). Bounds on
/// an effect parameter free it (the effect is fitted).
pub fn problem(bounds: &[String], fix: &[String]) -> Result<ProblemSpec> {
    let mut spec = ProblemSpec::default();
    let mut bounded = Vec::new();
    for list in bounds {
        for (k, v) in pairs(list).context("--bounds")? {
            let id = param(k).context("--bounds")?;
            if bounded.contains(&id) {
                bail!("--bounds: {k} is bounded twice");
            }
            bounded.push(id);
            let (lo, hi) = v
                .split_once(':')
                .ok_or_else(|| anyhow!("--bounds: {k} needs LO:HI, got '{v}'"))?;
            let lo = number(k, lo).context("--bounds")?;
            let hi = number(k, hi).context("--bounds")?;
            if lo >= hi {
                bail!("--bounds: {k} has lo {lo} >= hi {hi}");
            }
            // A range of more than twelve decades is no bound: the search's unit cube would
            // resolve nothing within it.
            if lo > 0.0 && hi / lo > 1e12 {
                bail!("--bounds: {k} = {lo}:{hi} spans more than 12 decades; narrow it to the motor at hand");
            }
            spec.set_bounds(id, lo, hi)
                .map_err(|e| anyhow!("--bounds: {e}"))?;
            if !id.is_motor() {
                spec.free(id);
            }
        }
    }
    let mut fixed = Vec::new();
    for list in fix {
        for (k, v) in pairs(list).context("--fix")? {
            let id = param(k).context("--fix")?;
            if fixed.contains(&id) {
                bail!("--fix: {k} is fixed twice");
            }
            if bounded.contains(&id) {
                bail!("--fix: {k} is given bounds too: fix it or bound it, not both");
            }
            fixed.push(id);
            let x = number(k, v).context("--fix")?;
            spec.fix(id, x).map_err(|e| anyhow!("--fix: {e}"))?;
        }
    }
    Ok(spec)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn motor_needs_all_five_and_rejects_unknown_names() {
        let p = parse_motor("ra=1,la=0.01,j=0.1,b=0.01,kv=0.5").unwrap();
        assert_eq!(p.get(ParamId::J), 0.1);
        assert!(parse_motor("ra=1,la=0.01")
            .unwrap_err()
            .to_string()
            .contains("missing j"));
        assert!(parse_motor("ra=1,xx=2").is_err());
        assert!(parse_motor("ra=-1,la=0.01,j=0.1,b=0.01,kv=0.5").is_err());
    }

    #[test]
    fn bounds_and_fix() {
        let s = problem(&["ra=1:5".into(), "tc=0:0.2".into()], &["kv=0.3".into()]).unwrap();
        assert_eq!(s.bounds[ParamId::Ra.index()], (1.0, 5.0));
        assert!(s.free[ParamId::Tc.index()]);
        assert!(!s.free[ParamId::Kv.index()]);
        assert_eq!(s.base.get(ParamId::Kv), 0.3);
        assert!(problem(&["ra=5:1".into()], &[]).is_err());
        assert!(problem(&["foo=1:2".into()], &[]).is_err());
        assert!(problem(&["ra=1".into()], &[]).is_err());
    }

    #[test]
    fn effects() {
        let mut p = ModelParams::SEED_MOTOR;
        apply_effect(&mut p, "tacho_ripple:amp=0.02,cycles=8").unwrap();
        assert_eq!(p.get(ParamId::RippleCycles), 8.0);
        assert!(apply_effect(&mut p, "coulomb_friction").is_err());
        assert!(apply_effect(&mut p, "warp_drive:x=1").is_err());
        assert!(apply_effect(&mut p, "sensor_delay:amp=1").is_err());
    }
}
