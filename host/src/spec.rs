//! Parsing of the parameter arguments: `--motor ra=..,la=..`, `--effect NAME:key=val,...`,
//! `--bounds ra=LO:HI,...` and `--fix ra=V,...`.
//!
//! Each argument is parsed by clap through a value parser here ([`parse_motor`],
//! [`parse_effect`], [`parse_bounds`], [`parse_fix`]), so that a malformed one is a usage
//! error (exit status 2) naming the option. What only the arguments together can tell (a
//! parameter bounded twice, fixed and bounded, an effect that the motor cannot carry) is
//! checked when they are applied, an error of status 1.

use anyhow::{bail, Result};
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::model::effects::Effect;
use motor_id_shared::{ModelParams, ParamId};

/// Split `a=1,b=2` into pairs; empty items are refused.
fn pairs(list: &str) -> Result<Vec<(&str, &str)>, String> {
    list.split(',')
        .map(|item| {
            let item = item.trim();
            item.split_once('=')
                .map(|(k, v)| (k.trim(), v.trim()))
                .filter(|(k, v)| !k.is_empty() && !v.is_empty())
                .ok_or_else(|| format!("expected key=value, got '{item}'"))
        })
        .collect()
}

fn number(key: &str, text: &str) -> Result<f32, String> {
    let x: f32 = text
        .parse()
        .map_err(|_| format!("{key}: '{text}' is not a number"))?;
    if !x.is_finite() {
        return Err(format!("{key}: '{text}' is not a finite number"));
    }
    Ok(x)
}

fn param(name: &str) -> Result<ParamId, String> {
    ParamId::from_name(name).ok_or_else(|| {
        let all: Vec<&str> = ParamId::ALL.iter().map(|p| p.name()).collect();
        format!("unknown parameter '{name}' (known: {})", all.join(", "))
    })
}

/// `--motor ra=..,la=..,j=..,b=..,kv=..`: all five motor parameters, nothing else (a clap
/// value parser).
pub fn parse_motor(text: &str) -> Result<ModelParams, String> {
    let mut p = ModelParams::PAPER_MOTOR;
    let mut seen = [false; 5];
    for (k, v) in pairs(text)? {
        let id = param(k)?;
        if !id.is_motor() {
            return Err(format!(
                "'{k}' is an effect parameter; give it with --effect"
            ));
        }
        let x = number(k, v)?;
        let ok = if id == ParamId::B { x >= 0.0 } else { x > 0.0 };
        if !ok {
            return Err(format!(
                "{k} must be {}",
                if id == ParamId::B { ">= 0" } else { "> 0" }
            ));
        }
        // Positive, yet below what the model takes (a subnormal f32): refused here, as a
        // usage error, rather than by the model later.
        let (lo, _) = id.physical_range();
        if x < lo {
            return Err(format!(
                "{k} = {x:e} is below {lo:e}, the smallest it can be"
            ));
        }
        p.set(id, x);
        seen[id.index()] = true;
    }
    if let Some(missing) = ParamId::MOTOR.iter().find(|id| !seen[id.index()]) {
        return Err(format!(
            "missing {} (give ra, la, j, b and kv)",
            missing.name()
        ));
    }
    Ok(p)
}

/// One `--effect NAME:key=val,...`: an effect and the values of its parameters, each within
/// its physical range.
#[derive(Clone, Debug, PartialEq)]
pub struct EffectSpec {
    /// The effect.
    pub effect: Effect,
    /// Its parameters' values, in the order given.
    pub values: Vec<(ParamId, f32)>,
}

impl EffectSpec {
    /// Add the effect to `p`; an error when the motor with it is no valid model.
    pub fn apply(&self, p: &mut ModelParams) -> Result<()> {
        for &(id, x) in &self.values {
            p.set(id, x);
        }
        if let Err(e) = p.validate() {
            bail!("--effect {}: {e}", self.effect.name());
        }
        Ok(())
    }
}

/// Add every effect of `specs` to `p`, each at most once: an effect given twice (the last
/// would silently win) is refused.
pub fn apply_effects(specs: &[EffectSpec], p: &mut ModelParams) -> Result<()> {
    for (k, e) in specs.iter().enumerate() {
        if specs[..k].iter().any(|earlier| earlier.effect == e.effect) {
            bail!(
                "--effect {} is given twice: give each effect once, with all its parameters",
                e.effect.name()
            );
        }
        e.apply(p)?;
    }
    Ok(())
}

/// `--effect NAME:key=val,...` (a clap value parser).
pub fn parse_effect(text: &str) -> Result<EffectSpec, String> {
    let (name, rest) = text.split_once(':').unwrap_or((text, ""));
    let name = name.trim();
    let effect = Effect::from_name(name).ok_or_else(|| {
        let all: Vec<&str> = Effect::ALL.iter().map(|e| e.name()).collect();
        format!("unknown effect '{name}' (known: {})", all.join(", "))
    })?;
    let keys: Vec<&str> = effect.params().iter().map(|id| id.short_key()).collect();
    if rest.trim().is_empty() {
        return Err(format!(
            "{name}: give its parameters, e.g. {name}:{}=...",
            keys.join("=...,")
        ));
    }
    let mut values = Vec::new();
    for (k, v) in pairs(rest).map_err(|e| format!("{name}: {e}"))? {
        let id = effect
            .params()
            .iter()
            .copied()
            .find(|id| id.short_key() == k || id.name() == k)
            .ok_or_else(|| format!("{name}: unknown key '{k}' (known: {})", keys.join(", ")))?;
        let x = number(k, v).map_err(|e| format!("{name}: {e}"))?;
        let (lo, hi) = id.physical_range();
        if x < lo || x > hi {
            return Err(if hi < f32::MAX {
                format!("{name}: {k} = {x} is outside [{lo}, {hi}]")
            } else {
                format!("{name}: {k} = {x} is outside its range (at least {lo})")
            });
        }
        values.push((id, x));
    }
    Ok(EffectSpec { effect, values })
}

/// One `--bounds P=LO:HI,...`: parameters with their search ranges, each a valid bound.
#[derive(Clone, Debug, PartialEq)]
pub struct BoundsSpec(pub Vec<(ParamId, f32, f32)>);

/// `--bounds P=LO:HI,...` (a clap value parser).
pub fn parse_bounds(text: &str) -> Result<BoundsSpec, String> {
    let mut out = Vec::new();
    for (k, v) in pairs(text)? {
        let id = param(k)?;
        let (lo, hi) = v
            .split_once(':')
            .ok_or_else(|| format!("{k} needs LO:HI, got '{v}'"))?;
        // Blanks around LO and HI, as around every key and value (`ra = 1 : 5`).
        let lo = number(k, lo.trim())?;
        let hi = number(k, hi.trim())?;
        if lo >= hi {
            return Err(format!("{k} has lo {lo} >= hi {hi}"));
        }
        // A range of more than twelve decades is no bound: the search's unit cube would
        // resolve nothing within it.
        if lo > 0.0 && hi / lo > 1e12 {
            return Err(format!(
                "{k} = {lo}:{hi} spans more than 12 decades; narrow it to the motor at hand"
            ));
        }
        ProblemSpec::default()
            .set_bounds(id, lo, hi)
            .map_err(|e| e.to_string())?;
        out.push((id, lo, hi));
    }
    Ok(BoundsSpec(out))
}

/// One `--fix P=V,...`: parameters with the values they are held at, each within its
/// physical range.
#[derive(Clone, Debug, PartialEq)]
pub struct FixSpec(pub Vec<(ParamId, f32)>);

/// `--fix P=V,...` (a clap value parser).
pub fn parse_fix(text: &str) -> Result<FixSpec, String> {
    let mut out = Vec::new();
    for (k, v) in pairs(text)? {
        let id = param(k)?;
        let x = number(k, v)?;
        ProblemSpec::default()
            .fix(id, x)
            .map_err(|e| e.to_string())?;
        out.push((id, x));
    }
    Ok(FixSpec(out))
}

/// Apply `--bounds` and `--fix` to the default problem (paper's Table 1, motor free). Bounds on
/// an effect parameter free it (the effect is fitted).
pub fn problem(bounds: &[BoundsSpec], fix: &[FixSpec]) -> Result<ProblemSpec> {
    let mut spec = ProblemSpec::default();
    let mut bounded = Vec::new();
    for &(id, lo, hi) in bounds.iter().flat_map(|b| &b.0) {
        let k = id.name();
        if bounded.contains(&id) {
            bail!("--bounds: {k} is bounded twice");
        }
        bounded.push(id);
        if let Err(e) = spec.set_bounds(id, lo, hi) {
            bail!("--bounds: {e}");
        }
        if !id.is_motor() {
            spec.free(id);
        }
    }
    let mut fixed = Vec::new();
    for &(id, x) in fix.iter().flat_map(|f| &f.0) {
        let k = id.name();
        if fixed.contains(&id) {
            bail!("--fix: {k} is fixed twice");
        }
        if bounded.contains(&id) {
            bail!("--fix: {k} is given bounds too: fix it or bound it, not both");
        }
        fixed.push(id);
        if let Err(e) = spec.fix(id, x) {
            bail!("--fix: {e}");
        }
    }
    Ok(spec)
}

#[cfg(test)]
#[path = "spec_fuzz.rs"]
mod fuzz;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn motor_needs_all_five_and_rejects_unknown_names() {
        let p = parse_motor("ra=1,la=0.01,j=0.1,b=0.01,kv=0.5").unwrap();
        assert_eq!(p.get(ParamId::J), 0.1);
        assert!(parse_motor("ra=1,la=0.01")
            .unwrap_err()
            .contains("missing j"));
        assert!(parse_motor("ra=1,xx=2").is_err());
        assert!(parse_motor("ra=-1,la=0.01,j=0.1,b=0.01,kv=0.5").is_err());
        // Found by the spec fuzz target: a subnormal kv was taken, and the model refused it.
        let tiny = parse_motor("ra=1,la=0.01,j=0.1,b=0.01,kv=1e-44").unwrap_err();
        assert!(tiny.contains("kv = 1e-44 is below 1.1754944e-38"), "{tiny}");
    }

    #[test]
    fn bounds_and_fix() {
        let b = |t: &str| parse_bounds(t).unwrap();
        let f = |t: &str| parse_fix(t).unwrap();
        let s = problem(&[b("ra=1:5"), b("tc=0:0.2")], &[f("kv=0.3")]).unwrap();
        assert_eq!(s.bounds[ParamId::Ra.index()], (1.0, 5.0));
        assert!(s.free[ParamId::Tc.index()]);
        assert!(!s.free[ParamId::Kv.index()]);
        assert_eq!(s.base.get(ParamId::Kv), 0.3);
        assert!(parse_bounds("ra=5:1").unwrap_err().contains("lo 5 >= hi 1"));
        assert!(parse_bounds("foo=1:2").is_err());
        assert!(parse_bounds("ra=1").unwrap_err().contains("LO:HI"));
        assert!(parse_bounds("ra=-1:2").unwrap_err().contains("bound of ra"));
        assert!(parse_fix("ra=abc").unwrap_err().contains("not a number"));
        // Found by the spec fuzz target: blanks around the colon were not a number.
        assert_eq!(b(" ra = 1 : 5 ").0, vec![(ParamId::Ra, 1.0, 5.0)]);
        // What the arguments only tell together is checked when they are applied.
        assert!(problem(&[b("ra=1:2"), b("ra=1:3")], &[]).is_err());
        assert!(problem(&[b("ra=1:2")], &[f("ra=3")]).is_err());
        assert!(problem(&[], &[f("ra=3,ra=4")]).is_err());
    }

    #[test]
    fn effects() {
        let mut p = ModelParams::PAPER_MOTOR;
        parse_effect("tacho_ripple:amp=0.02,cycles=8")
            .unwrap()
            .apply(&mut p)
            .unwrap();
        assert_eq!(p.get(ParamId::RippleCycles), 8.0);
        assert!(parse_effect("coulomb_friction").is_err());
        assert!(parse_effect("warp_drive:x=1").is_err());
        assert!(parse_effect("sensor_delay:amp=1").is_err());
        assert!(parse_effect("coulomb_friction:tc=-1")
            .unwrap_err()
            .contains("outside"));
    }
}
