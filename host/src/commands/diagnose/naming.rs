//! A name only for what an effect explains.
//!
//! The significance rule ([`super::verdict`]) says that an effect lowers the held-out misfit
//! by more than noise fitting could; it does not say that the effect is the cause. An
//! effect can shave part of a misfit whose cause the catalogue does not hold: on records of
//! the independent reference plant whose drive limits its current (the log keeps the
//! commanded voltage), `current_offset` or `armature_reaction` passed the rule and were
//! named, while the model with them kept 84 % of the held-out speed misfit above the noise
//! (tests/examples/blind_check.rs, case `limit`).
//!
//! The rule here: when the final model's held-out misfit on a channel is still
//! significantly above its floor ([`super::remainder::unexplained`]) and the named effects
//! together remove less than [`EXPLAINED_SHARE`] of that channel's misfit above the floor,
//! they leave most of the excess: the data cannot tell a cause from a stand-in, so none is
//! named. Each is reported as a *partial stand-in*, with the share of the baseline's excess
//! above the floor its step of the search removed (on the channel that leaves most of its
//! excess) and why it is not named. A true effect
//! that accounts for its part leaves the final model near the floor (its remainder is then
//! explained) or leaves a remainder smaller than what it removed. Every channel counts:
//! each effect of the catalogue acts on both the speed and, through paper Eq. 1-4, the
//! current.
//!
//! A second rule, [`unpinned_own`]: a named effect's own parameters must be pinned by the
//! final fit. An effect whose form the records do not show (a parameter free to slide)
//! only shaves the misfit; it is a partial stand-in, the others stay named, and the
//! verdict says unexplained (a stand-in's share of the misfit has no named cause). It
//! needs current: from the speed alone the motor's flat directions (paper Eq. 6) take a
//! torque-like parameter with them (Coulomb friction's `tc` scales with J and B), so it is
//! unpinned whatever the records show. It is
//! judged on the final model only: on a model that lacks another effect, the structured
//! residual widens every deviation (asymmetric friction's `ka` before the bridge dead
//! time beside it is added). Nor does the search pass it over for the next best: that is
//! often its look-alike (a bridge dead time whose band the records do not pin, passed
//! over, left a brush drop named beside asymmetric friction), so no name is given (unless
//! the fit took its form to its limit's, below).
//!
//! A third rule, [`misfit_where_it_acts`]: each catalogue entry names the operating regime
//! where its form shows most distinctly (`EffectSpec::shows_in`: near standstill for the
//! frictions, a brush drop's and a bridge's dead zones and a current offset; start-ups for
//! a current limit; low speed for cogging; high speed for a fan load; acceleration for
//! armature reaction; transients for a sensor delay). A named effect must leave the final
//! model's held-out misfit there within [`OWN_REGIME_RATIO`] times the floor on every
//! channel: a stand-in of another form shaves the misfit overall and leaves it where the
//! forms differ (a brush drop for a bridge dead time: the speed at its floor, but near
//! standstill, where the drop holds the current at zero and the bridge's band lets it
//! flow, the held-out current misfit 2-5 times its noise). It is then a partial stand-in
//! and the verdict unexplained; the others stay named.
//!
//! A fourth rule, look-alikes ([`super::found::LookAlike`], judged by the search): an
//! effect added where an entry of another form passed the significance rule at the same
//! step and predicted the held-out records about as well, and still does in the effect's
//! place in the final model (its own regime kept within [`OWN_REGIME_RATIO`] of the noise),
//! is a partial stand-in (the records do not tell the two forms apart). Before it, the
//! search takes an entry's limit in its place where the fit put the form there
//! ([`super::found::at_limit`]: a bridge dead time whose band is at its floor is a brush
//! drop): a dead time fitted to a brush drop, its band at the floor and unpinned, had
//! left the brush drop unnamed.
//!
//! What no rule catches: a stand-in whose model reaches the floor everywhere with its
//! parameters pinned while the true cause is not in the catalogue (a cause the records
//! barely show beyond what the stand-in mimics: cogging at a few per cent of the stall
//! torque is taken for static friction; docs/measurements/blind-checks.md, "Each entry
//! left out").

use crate::report::Num;
use motor_id_shared::fit::identifiability::Identifiability;
use motor_id_shared::model::effects::regime::Regime;
use motor_id_shared::model::effects::Effect;
use motor_id_shared::ParamId;
use serde::Serialize;

/// Smallest share of a channel's held-out misfit above its floor that the named effects
/// must remove, when what they leave is still significantly above the floor: most of it.
pub const EXPLAINED_SHARE: f32 = 0.5;

/// A named effect's own regime ([`motor_id_shared::model::effects::EffectSpec::shows_in`])
/// may hold the final model's held-out misfit up to this many times the channel's floor.
/// Chosen on the blind harness (docs/measurements/blind-checks.md): a true effect, its model
/// right, leaves 0.93-1.2 there; a stand-in whose form is not the cause's (a brush drop for
/// a bridge's dead time, a current offset for asymmetric friction) 2-6 on the current.
pub const OWN_REGIME_RATIO: f32 = 1.5;

/// Fewest held-out samples in an effect's own regime for the rule above to judge it.
pub const OWN_REGIME_SAMPLES: usize = 200;

/// A named effect whose own regime keeps the misfit: in the regime where its form shows,
/// the final model's held-out misfit on `channel` is `over_floor` times the floor.
#[derive(Debug, Clone, PartialEq)]
pub struct MisfitWhereItActs {
    /// The effect.
    pub effect: Effect,
    /// Its regime's name.
    pub regime: &'static str,
    /// `speed` or `current`.
    pub channel: &'static str,
    /// The held-out RMSE there over the channel's floor.
    pub over_floor: f32,
}

impl MisfitWhereItActs {
    /// Why it is not named, in words.
    pub fn why(&self) -> String {
        format!(
            "in {}, where its form shows, the final model's held-out {} misfit is {:.1} x its floor: its form does not account for what it removes",
            self.regime, self.channel, self.over_floor
        )
    }
}

/// The named effects (`named`) whose own regime keeps the final model's held-out misfit
/// above `ratio` times the floor on a channel it acts on (the rule's [`OWN_REGIME_RATIO`];
/// [`super::remainder::UNEXPLAINED_RATIO`] where the search tells two forms apart):
/// `in_regime` gives `(rmse in the regime, samples)` of a channel's held-out residual for a
/// regime; the speed is judged against `speed_floor`, the current against its noise. An
/// effect's worst channel.
pub fn misfit_where_it_acts(
    named: &[Effect],
    in_regime: impl Fn(&Regime, &'static str) -> Option<(f64, usize)>,
    speed_floor: f32,
    current_noise: Option<f32>,
    ratio: f32,
) -> Vec<MisfitWhereItActs> {
    let mut out = Vec::new();
    for &effect in named {
        let spec = effect.spec();
        let Some(regime) = spec.shows_in else {
            continue;
        };
        // Judged on the channels it acts on only (a current sensor's offset leaves the
        // speed to the motor, a speed reading's lag the current).
        let floors = [
            ("speed", Some(speed_floor).filter(|_| spec.acts_on_speed())),
            ("current", current_noise.filter(|_| spec.acts_on_current())),
        ];
        let worst = floors
            .into_iter()
            .filter_map(|(channel, floor)| {
                let floor = floor.filter(|f| *f > 0.0)?;
                let (rmse, n) = in_regime(&regime, channel)?;
                (n >= OWN_REGIME_SAMPLES).then_some((channel, rmse as f32 / floor))
            })
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((channel, over_floor)) = worst.filter(|w| w.1 > ratio) {
            out.push(MisfitWhereItActs {
                effect,
                regime: regime.name,
                channel,
                over_floor,
            });
        }
    }
    out
}

/// One channel's held-out RMSE: before any effect, after every named one, and its floor.
#[derive(Clone, Copy, Debug)]
pub struct Channel {
    /// Baseline's held-out RMSE.
    pub before: f32,
    /// The final model's held-out RMSE.
    pub after: f32,
    /// What no model can remove (noise, or the repeatability floor).
    pub floor: f32,
    /// The final model's misfit is significantly above the floor.
    pub unexplained: bool,
    /// What the channel is called in the reasons given.
    pub name: &'static str,
}

impl Channel {
    /// Share of the misfit above the floor that going from `before` to `after` removes, in
    /// [0, 1] (in variance: independent errors add in variance).
    pub fn share(&self, before: f32, after: f32) -> f32 {
        let (b2, a2, f2) = (before.powi(2), after.powi(2), self.floor.powi(2));
        let excess = (self.before.powi(2) - f2).max(f32::MIN_POSITIVE);
        ((b2 - a2.max(f2)) / excess).clamp(0.0, 1.0)
    }

    /// Share of the baseline's excess the final model removes.
    pub fn removed(&self) -> f32 {
        self.share(self.before, self.after)
    }

    /// The named effects leave most of this channel's excess, and what they leave is
    /// significant.
    fn leaves_most(&self) -> bool {
        self.unexplained && self.removed() < EXPLAINED_SHARE
    }
}

/// An effect the search found significant but that is not named: it removes part of the
/// misfit, not what its cause would.
#[derive(Serialize, Debug, Clone)]
pub struct PartialStandIn {
    /// The effect.
    pub name: &'static str,
    /// Share of the baseline's held-out misfit above the floor that its step of the search
    /// removed, on `channel`.
    pub share_of_excess: Num,
    /// The channel that leaves most of its misfit (`speed` or `current`).
    pub channel: &'static str,
    /// Why it is not named.
    pub why: String,
    /// It is in the final model (a step of the search's chain), not an entry passed over.
    #[serde(skip)]
    pub in_model: bool,
}

/// Why the named effects are not causes on these `channels`, and the channel that leaves
/// the largest share of its excess; `None` when they may be named (every channel explained,
/// or most of each channel's excess removed).
pub fn stand_in_reason(channels: &[Channel]) -> Option<(String, usize)> {
    let leaving: Vec<usize> = (0..channels.len())
        .filter(|&k| channels[k].leaves_most())
        .collect();
    let worst = *leaving
        .iter()
        .min_by(|&&a, &&b| channels[a].removed().total_cmp(&channels[b].removed()))?;
    let left: Vec<String> = leaving
        .iter()
        .map(|&k| {
            format!(
                "with every effect the search found, {:.0} % of the held-out {} misfit above its floor is left",
                100.0 * (1.0 - channels[k].removed()),
                channels[k].name
            )
        })
        .collect();
    let why = format!(
        "{}: it may stand in for a cause the catalogue does not hold",
        left.join("; ")
    );
    Some((why, worst))
}

/// The effects of the search's chain as partial stand-ins, each step's share of
/// `channel`'s excess from `steps` (that channel's held-out RMSE after each effect, in
/// order).
pub fn stand_ins(
    names: &[&'static str],
    steps: &[f32],
    channel: &Channel,
    why: &str,
) -> Vec<PartialStandIn> {
    let mut before = channel.before;
    names
        .iter()
        .zip(steps)
        .map(|(name, &after)| {
            let share = channel.share(before, after);
            before = after;
            PartialStandIn {
                name,
                share_of_excess: Num(share),
                channel: channel.name,
                why: why.to_string(),
                in_model: true,
            }
        })
        .collect()
}

/// The own free parameters of `effect` that the final fit `identifiability` does not pin:
/// an effect whose form the records do not show (a dead-time band narrower than the
/// current's resolution standing in for a brush drop, a fan load whose coefficient is free
/// to slide standing in for static friction) is a stand-in, not a cause. Parameters held
/// fixed (told) are not judged, nor phases: the analysis measures a parameter whose range
/// holds 0 relative to `max(|p|, 1 % of the range)`, which for an angle near 0 calls a
/// deviation of a few hundredths of a radian unpinned (cogging's phase beside a dead time,
/// 5 kHz: named right once phases were left to their amplitude).
pub fn unpinned_own(effect: Effect, identifiability: &Identifiability) -> Vec<&'static str> {
    effect
        .params()
        .iter()
        .filter(|id| !matches!(id, ParamId::CogPhase | ParamId::RipplePhase))
        .filter(|id| {
            identifiability
                .params
                .iter()
                .any(|c| c.id == **id && !c.pinned)
        })
        .map(|id| id.name())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use motor_id_shared::fit::identifiability::ParamCertainty;

    fn certainty(id: ParamId, pinned: bool) -> ParamCertainty {
        ParamCertainty {
            id,
            value: 1.0,
            pinned,
            std: pinned.then_some(0.01),
        }
    }

    fn analysis(params: &[ParamCertainty]) -> Identifiability {
        Identifiability {
            rank: 0,
            params: params.iter().copied().collect(),
            combinations: heapless::Vec::new(),
            unpinned: heapless::Vec::new(),
            evaluations: 0,
        }
    }

    #[test]
    fn an_effect_is_a_stand_in_where_its_own_regime_keeps_the_misfit() {
        // Brush drop shows near standstill; winding heating in no regime.
        let named = [Effect::BrushDrop, Effect::WindingHeating];
        let at = |speed: f64, current: f64, n: usize| {
            move |regime: &Regime, channel: &'static str| {
                assert_eq!(regime.short, "standstill");
                Some((if channel == "speed" { speed } else { current }, n))
            }
        };
        // Judged against a speed floor of 1 and the rule's ratio.
        let acts = |named: &[Effect], regime, current_noise| {
            misfit_where_it_acts(named, regime, 1.0, current_noise, OWN_REGIME_RATIO)
        };
        // The current's misfit there twice its noise (0.1 A against 0.05): its worst channel.
        let found = acts(&named, at(1.1, 0.1, 1000), Some(0.05));
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].effect, Effect::BrushDrop);
        assert_eq!(found[0].channel, "current");
        assert!((found[0].over_floor - 2.0).abs() < 1e-6);
        assert!(
            found[0].why().contains("near standstill"),
            "{}",
            found[0].why()
        );
        // Within 1.5 times the floor on both: named.
        assert!(acts(&named, at(1.4, 0.07, 1000), Some(0.05)).is_empty());
        // The speed's misfit there over the rule, without current.
        assert_eq!(acts(&named, at(1.6, 0.0, 1000), None)[0].channel, "speed");
        // Too few samples in the regime to judge.
        assert!(acts(&named, at(3.0, 0.3, 199), Some(0.05)).is_empty());
        // A current sensor's offset is judged on the current only: the speed's misfit near
        // standstill is not its doing.
        let offset = [Effect::CurrentOffset];
        assert!(acts(&offset, at(3.0, 0.05, 1000), Some(0.05)).is_empty());
        assert_eq!(
            acts(&offset, at(1.0, 0.1, 1000), Some(0.05))[0].channel,
            "current"
        );
    }

    #[test]
    fn an_effect_is_judged_on_its_own_free_parameters_only() {
        // A dead-time band the records do not pin: a stand-in, whatever the motor's.
        let loose = analysis(&[
            certainty(ParamId::J, false),
            certainty(ParamId::Vdt, true),
            certainty(ParamId::Ib, false),
        ]);
        assert_eq!(unpinned_own(Effect::BridgeDeadtime, &loose), ["ib"]);
        // Both pinned: named, though the motor's J is not.
        let pinned = analysis(&[
            certainty(ParamId::J, false),
            certainty(ParamId::Vdt, true),
            certainty(ParamId::Ib, true),
        ]);
        assert!(unpinned_own(Effect::BridgeDeadtime, &pinned).is_empty());
        // Cogging told its detents per revolution (held fixed, not in the analysis); its
        // phase is not judged, its amplitude is.
        let told = analysis(&[
            certainty(ParamId::CogAmp, true),
            certainty(ParamId::CogPhase, false),
        ]);
        assert!(unpinned_own(Effect::Cogging, &told).is_empty());
        let faint = analysis(&[
            certainty(ParamId::CogAmp, false),
            certainty(ParamId::CogPhase, false),
        ]);
        assert_eq!(unpinned_own(Effect::Cogging, &faint), ["cog_amp"]);
    }

    fn speed(before: f32, after: f32, floor: f32) -> Channel {
        Channel {
            before,
            after,
            floor,
            unexplained: after > 1.2 * floor,
            name: "speed",
        }
    }

    #[test]
    fn an_effect_that_leaves_most_of_the_excess_is_a_stand_in() {
        // The current-limit case: 25.2 -> 23.1 rad/s against 1.67 of noise.
        let limit = speed(25.23, 23.08, 1.67);
        assert!(
            (limit.removed() - 0.164).abs() < 0.01,
            "{}",
            limit.removed()
        );
        let (why, _) = stand_in_reason(&[limit]).expect("a stand-in");
        assert!(why.contains("84 % of the held-out speed misfit"), "{why}");
        let partial = stand_ins(&["current_offset"], &[23.08], &limit, &why);
        assert_eq!(partial.len(), 1);
        assert!((partial[0].share_of_excess.0 - 0.164).abs() < 0.01);
    }

    #[test]
    fn an_effect_that_explains_its_part_is_named() {
        // At the floor: explained, whatever the share.
        assert!(stand_in_reason(&[speed(10.0, 1.1, 1.0)]).is_none());
        // Above the floor but most of the excess gone (a second cause left): named.
        assert!(stand_in_reason(&[speed(10.0, 4.0, 1.0)]).is_none());
        // A channel that leaves most of it decides, whichever it is.
        let current = Channel {
            name: "current",
            ..speed(1.39, 1.09, 0.05)
        };
        let (why, k) = stand_in_reason(&[speed(10.0, 1.1, 1.0), current]).expect("current");
        assert!(why.contains("current misfit"), "{why}");
        assert_eq!(k, 1);
    }

    #[test]
    fn each_step_gets_its_own_share_and_the_shares_add_up() {
        let c = speed(10.0, 6.0, 1.0);
        let partial = stand_ins(&["a", "b"], &[8.0, 6.0], &c, "why");
        let total: f32 = partial.iter().map(|p| p.share_of_excess.0).sum();
        assert!((total - c.removed()).abs() < 1e-5, "{total}");
        assert!(partial[0].share_of_excess.0 > partial[1].share_of_excess.0);
    }
}
