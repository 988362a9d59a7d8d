//! The commissioning limits as command-line options, one set for `commission --sim` and
//! `board config`: each option left out keeps its base value (the defaults on the virtual
//! board, what the board holds for `board config`).

use clap::Args;
use motor_id_shared::wire::limits::Limits;

/// `--voltage`, `--current`, `--speed`, `--budget`.
#[derive(Args, Debug, Clone, Copy, Default)]
pub struct LimitArgs {
    /// Largest armature voltage the drive applies [V] (default 50).
    #[arg(long, value_parser = within(f32::MIN_POSITIVE, 1e6))]
    pub voltage: Option<f32>,
    /// Current limit (trip) [A] (default 40).
    #[arg(long, value_parser = within(f32::MIN_POSITIVE, 1e6))]
    pub current: Option<f32>,
    /// Speed limit (trip) [rad/s] (default 500).
    #[arg(long, value_parser = within(f32::MIN_POSITIVE, 1e6))]
    pub speed: Option<f32>,
    /// Time budget of the experiment, probe included [s] (5 to 86,400; default 60).
    #[arg(long, value_parser = within(Limits::MIN_BUDGET, 86_400.0))]
    pub budget: Option<f32>,
}

impl LimitArgs {
    /// `base` with every limit given replaced.
    pub fn over(&self, base: Limits) -> Limits {
        Limits {
            voltage: self.voltage.unwrap_or(base.voltage),
            current: self.current.unwrap_or(base.current),
            speed: self.speed.unwrap_or(base.speed),
            budget: self.budget.unwrap_or(base.budget),
        }
    }

    /// Whether any limit is given.
    pub fn any(&self) -> bool {
        [self.voltage, self.current, self.speed, self.budget]
            .iter()
            .any(Option::is_some)
    }
}

/// A value parser for a number from `lo` to `hi` (both included; `lo` may be
/// `f32::MIN_POSITIVE` for "above 0"): NaN, infinities and anything outside are refused.
pub fn within(lo: f32, hi: f32) -> impl Fn(&str) -> Result<f32, String> + Clone + Send + Sync {
    move |text: &str| match text.parse::<f32>() {
        Ok(x) if (lo..=hi).contains(&x) => Ok(x),
        Ok(_) if lo == f32::MIN_POSITIVE => Err(format!("must be above 0 and at most {hi}")),
        Ok(_) => Err(format!("must be from {lo} to {hi}")),
        Err(_) => Err(format!("'{text}' is not a number")),
    }
}

/// The limits as one line for people.
pub fn limits_text(l: &Limits) -> String {
    format!(
        "limits: {} V, {} A, {} rad/s, time budget {} s",
        l.voltage, l.current, l.speed, l.budget
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn given_limits_replace_the_base_and_the_rest_stay() {
        let given = LimitArgs {
            current: Some(10.0),
            budget: Some(30.0),
            ..LimitArgs::default()
        };
        let l = given.over(Limits::DEFAULT);
        assert_eq!(
            (l.voltage, l.current, l.speed, l.budget),
            (50.0, 10.0, 500.0, 30.0)
        );
        assert!(given.any());
        assert!(!LimitArgs::default().any());
    }

    #[test]
    fn numbers_outside_their_range_are_refused() {
        let budget = within(Limits::MIN_BUDGET, 86_400.0);
        assert!(budget("4.9").is_err() && budget("nan").is_err() && budget("1e9").is_err());
        assert_eq!(budget("30"), Ok(30.0));
        let positive = within(f32::MIN_POSITIVE, 1e6);
        assert!(positive("0").unwrap_err().contains("above 0"));
    }
}
