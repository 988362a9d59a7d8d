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
        let bound = free.and(at_bound(v, spec.bounds[p.index()]));
        let status = match (free, bound) {
            (Some(_), Some(b)) => format!("at its bound {} (not measured: widen --bounds)", sig(b)),
            (Some(c), None) if c.pinned => match c.std {
                Some(sd) if v == 0.0 => format!("+- {} {} (at zero)", sig(sd), p.unit()),
                Some(sd) if sd > v.abs() => "NOT pinned (uncertainty above 100 %)".into(),
                Some(sd) => format!("+- {:.3} %", 100.0 * sd / v.abs()),
                None => "pinned".into(),
            },
            (Some(_), None) => "NOT pinned by this data".into(),
            (None, _) if spec.free[p.index()] => String::new(),
            (None, _) if p.is_motor() || v != 0.0 && p != ParamId::RippleCycles => "fixed".into(),
            (None, _) => continue,
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
        // Flat: the data says nothing along it. Loose: it does, more loosely than pinned.
        s += &match d.std.is_finite() {
            true => format!(
                "  loose along {} (log scale): one deviation {:.3} along it\n",
                terms.join(" "),
                d.std
            ),
            false => format!("  flat along {} (log scale)\n", terms.join(" ")),
        };
    }
    if !ident.all_pinned() {
        s += &unpinned_advice(id.cost.rmse_current.is_some());
    }
    s
}

/// The bound `value` sits at, if any: within 0.1 % of the range of it (on a log scale when
/// both bounds are positive, as the search runs). A fit that ends there was stopped by the
/// bound, so the value is not a measurement.
pub(crate) fn at_bound(value: f32, (lo, hi): (f32, f32)) -> Option<f32> {
    let near = |bound: f32| match lo > 0.0 && value > 0.0 {
        true => (value / bound).ln().abs() <= 1e-3 * (hi / lo).ln(),
        false => (value - bound).abs() <= 1e-3 * (hi - lo),
    };
    [lo, hi].into_iter().find(|&b| b.is_finite() && near(b))
}

/// What to add when some parameters are not pinned: the armature current only when the
/// records lack it.
fn unpinned_advice(with_current: bool) -> String {
    let add = match with_current {
        false => {
            "add the armature current (column i), a known load-torque step (column tl), \
                  a longer or richer excitation,"
        }
        true => {
            "add a known load-torque step (column tl), a longer or richer excitation \
                 (the speed must change on the mechanical time scale),"
        }
    };
    format!(
        "  parameters marked NOT pinned fit the data equally well over a range: {add} or fix \
         what was measured otherwise (--fix ra=...)\n"
    )
}

#[cfg(test)]
mod tests {
    use super::{sig, unpinned_advice};

    #[test]
    fn a_value_at_a_bound_is_named_so() {
        assert_eq!(super::at_bound(2.0, (0.1, 2.0)), Some(2.0));
        assert_eq!(super::at_bound(0.1001, (0.1, 2.0)), Some(0.1));
        assert_eq!(super::at_bound(1.0, (0.1, 2.0)), None);
        assert_eq!(super::at_bound(0.0, (0.0, 0.5)), Some(0.0));
        assert_eq!(super::at_bound(0.01, (0.0, 0.5)), None);
        assert_eq!(super::at_bound(1.5e-6, (1e-6, 1.0)), None);
    }

    #[test]
    fn the_advice_asks_for_current_only_where_it_is_missing() {
        assert!(unpinned_advice(false).contains("column i"));
        assert!(!unpinned_advice(true).contains("column i"));
        assert!(unpinned_advice(true).contains("column tl"));
    }

    #[test]
    fn significant_digits() {
        assert_eq!(sig(3.412), "3.41200");
        assert_eq!(sig(0.0573), "0.0573000");
        assert_eq!(sig(1.3e-5), "1.30000e-5");
        assert_eq!(sig(0.0), "0");
        assert_eq!(sig(1234.5), "1234.50");
    }
}
