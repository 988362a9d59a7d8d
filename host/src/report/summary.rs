//! The text summary of an identification, printed on stdout by `identify` and `demo`.

use super::identify::FitQuality;
use motor_id_shared::fit::identify::Identification;
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::ParamId;

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
            p.unit(),
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
    if id.widened > 0 {
        s += &format!(
            "the pipeline's fit stayed above the noise: the search was widened {} time(s) (its \
             escalation's wider FFO) and the best fit kept\n",
            id.widened
        );
    }
    let quality = FitQuality::of(id);
    let channels = [("speed", Some(quality.speed)), ("current", quality.current)];
    for (name, q) in channels.into_iter().filter_map(|(n, q)| Some((n, q?))) {
        if !q.model_adequate {
            s += &format!(
                "warning: the {name} fit is {:.1} x its measured noise: the model misses \
                 something in this data (an unmodelled effect?); the uncertainties below \
                 assume white residuals and are optimistic\n",
                q.rmse_over_noise.0
            );
        }
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
