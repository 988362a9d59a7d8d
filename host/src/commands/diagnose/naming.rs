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
//! over, left a brush drop named beside asymmetric friction), so no name is given.
//!
//! What neither rule catches: a stand-in whose model reaches the floor with its parameters
//! pinned (a cause the records barely show beyond what the stand-in mimics: cogging at a
//! few per cent of the stall torque is taken for static friction, a brush drop for a bridge
//! dead time and back; docs/measurements/blind-checks.md, "Each entry left out").

use crate::report::Num;
use motor_id_shared::fit::identifiability::Identifiability;
use motor_id_shared::model::effects::Effect;
use motor_id_shared::ParamId;
use serde::Serialize;

/// Smallest share of a channel's held-out misfit above its floor that the named effects
/// must remove, when what they leave is still significantly above the floor: most of it.
pub const EXPLAINED_SHARE: f32 = 0.5;

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
