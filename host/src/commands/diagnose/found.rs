//! What the search over the catalogue found ([`super::search`]): the baseline, every
//! effect scored against it, the chain of effects named and the stand-ins passed over, and
//! the questions the report asks of them (the first effect, the final model, whether an
//! effect is significant, which of an extension and its parent the data needs).

use super::data::Scored;
use super::naming::unpinned_own;
use super::regimes::WhereReport;
use super::verdict::{predicts_better, significant, Holdout};
use super::widening::WidenedRefit;
use motor_id_shared::model::effects::{Effect, Scales};

/// What the search found.
pub struct Search {
    /// The model without effects.
    pub baseline: Scored,
    /// The held-out records' scales.
    pub holdout: Holdout,
    /// The records' scales.
    pub scales: Scales,
    /// Where the baseline misfits.
    pub where_: WhereReport,
    /// Every effect of the catalogue added to the baseline, best held-out (joint) misfit
    /// first.
    pub scored: Vec<(Effect, Scored)>,
    /// The effects named, in the order they were added, each with the fit of the model up to
    /// it (the last: the final model). An effect that extends another stands for both.
    pub chain: Vec<(Effect, Scored)>,
    /// The fits of entries left out (`--without`) that a scored effect extends, the
    /// baseline plus each: the reference its own part is judged against ([`Search::needed`]).
    pub left_out_parents: Vec<(Effect, Scored)>,
    /// Effects significant against the baseline that are not named because they only
    /// match the entry they extend, which was left out: stand-ins for it, in the order
    /// found.
    pub standing_in: Vec<StandingIn>,
    /// Effects added at a step of the search where an entry of another form fitted the
    /// held-out records about as well ([`LookAlike`]).
    pub look_alikes: Vec<LookAlike>,
    /// The final model's fit widened before it was judged ([`super::widening`]).
    pub widened: Option<WidenedRefit>,
}

/// An effect the search added where an entry of another form (neither the entry it extends
/// nor an extension of it, nor a simpler form it holds as a limit) also passed the
/// significance rule at the same step, and the effect does not predict the held-out records
/// better than it ([`predicts_better`]): the records do not tell the two apart, so the
/// effect chosen is not named ([`super::report`]). Met at a step of the search, it is
/// weighed again on the final model (`search::confirmed`): the effect swapped for the
/// look-alike, everything refitted.
#[derive(Clone, Debug)]
pub struct LookAlike {
    /// The effect the search added.
    pub effect: Effect,
    /// The entry that fits about as well.
    pub alike: Effect,
    /// Held-out (joint) misfit with the effect, and with the look-alike instead (at the
    /// step the search met them; once confirmed, of the final model and of it swapped).
    pub effect_rmse: f32,
    /// See `effect_rmse`.
    pub alike_rmse: f32,
}

impl LookAlike {
    /// The closest look-alike of `chosen` among `others` (every effect with its fit at the
    /// same step of the search, each significant there): one of another form that
    /// `chosen` does not predict better. The training records do not judge it: on them
    /// each form fits its own way (a Coulomb friction and a bridge dead time are alike
    /// at steady speed, and only the held-out reversals tell them apart).
    /// Each effect comes with its held-out (joint) misfit.
    pub fn among(
        chosen: (Effect, f32),
        others: impl IntoIterator<Item = (Effect, f32)>,
        holdout: &Holdout,
    ) -> Option<LookAlike> {
        let (effect, effect_rmse) = chosen;
        others
            .into_iter()
            .filter(|(e, _)| !related(effect, *e) && !limit_of(effect, *e))
            .filter(|(_, alike)| !predicts_better(*alike, effect_rmse, holdout))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(alike, alike_rmse)| LookAlike {
                effect,
                alike,
                effect_rmse,
                alike_rmse,
            })
    }

    /// Why the effect is not named, in words.
    pub fn why(&self) -> String {
        format!(
            "with {} in its place the model predicts the held-out records about as well ({:.4} against {:.4}): they do not tell the two forms apart",
            self.alike.name(),
            self.alike_rmse,
            self.effect_rmse
        )
    }
}

/// The same entry, or one extends the other: not look-alikes (the extension's own rule,
/// [`Search::needed`], judges them).
fn related(a: Effect, b: Effect) -> bool {
    a == b || a.parent() == Some(b) || b.parent() == Some(a)
}

/// `simpler` is the limit of `general`'s form ([`Effect::limit`]): a brush drop is a bridge
/// dead time whose band `ib` vanishes (`-vdt clamp(i / ib, -1, 1)` tends to `-vb sign(i)`,
/// and no current flows within it). Where the general form predicts no better, the simpler
/// one stands: it is no look-alike of it (the converse is: a dead time whose band the
/// records cannot tell from none is not named over the brush drop that fits as well).
fn limit_of(simpler: Effect, general: Effect) -> bool {
    general.limit().is_some_and(|(limit, _)| limit == simpler)
}

/// A parameter lies at the floor of its search bounds when it is within this share of
/// their range above it. Chosen on the blind harness (docs/measurements/blind-checks.md):
/// a bridge dead time fitted to a brush drop puts its band within 0.5 % of the floor's
/// value (0.1 % of the largest current), fitted to a true dead time 2.6-46 % of the range
/// above it (9-139 times the floor; 72 cases, alone and beside each other entry).
pub const AT_FLOOR: f32 = 0.01;

/// The entry whose form `chosen`'s fit `fit` has reached: its [`Effect::limit`] parameter
/// at the floor of its search bounds ([`AT_FLOOR`]). The records then show the limit's form
/// only (a dead time with no band is a brush drop), and the search takes the limit's entry
/// in its place where that passed the significance rule at the same step: a form the
/// records do not show is not named (its band unpinned, the dead time was a partial
/// stand-in and the brush drop beside it went unnamed).
pub fn at_limit(chosen: Effect, fit: &Scored) -> Option<Effect> {
    let (limit, param) = chosen.limit()?;
    let (lo, hi) = fit.fit.spec.bounds[param.index()];
    let value = fit.fit.result.params.get(param);
    (value <= lo + AT_FLOOR * (hi - lo)).then_some(limit)
}

/// `effect`, the search's choice at a step with its fit `fit`, as the records show it: the
/// limit's entry in its place where the fit reached that form ([`at_limit`]) and the limit
/// `passed` the significance rule at the same step.
pub fn as_shown(
    effect: Effect,
    fit: &Scored,
    passed: impl Fn(Effect) -> bool,
    say: &dyn Fn(String),
) -> Effect {
    match at_limit(effect, fit).filter(|l| passed(*l)) {
        Some(limit) => {
            say(format!("{} at its limit: {}", effect.name(), limit.name()));
            limit
        }
        None => effect,
    }
}

/// `effect` with its fit `s` as a rival explanation of the effect the search adds at the
/// same step ([`LookAlike`]): its held-out (joint) misfit, unless its fit leaves its own
/// parameters unpinned (with current; [`unpinned_own`]): a form the records do not show is
/// no explanation to weigh against one they do (static friction whose `ws` slides beside
/// cogging told its detents, which it matches within 1 % on the held-out records).
pub fn rival(effect: Effect, s: &Scored, with_current: bool) -> Option<(Effect, f32)> {
    let shown = !with_current || unpinned_own(effect, &s.fit.result.identifiability).is_empty();
    shown.then_some((effect, s.holdout_joint))
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOLDOUT: Holdout = Holdout {
        noise: 1.0,
        signal_rms: 100.0,
        current_noise: None,
    };

    #[test]
    fn an_effect_is_a_look_alike_where_another_form_predicts_about_as_well() {
        use Effect::*;
        // 1 % apart at the noise floor's level: alike; 10 % better: told apart.
        let alike = LookAlike::among((BridgeDeadtime, 1.50), [(CoulombFriction, 1.515)], &HOLDOUT);
        assert_eq!(alike.map(|l| l.alike), Some(CoulombFriction));
        assert!(
            LookAlike::among((BridgeDeadtime, 1.50), [(CoulombFriction, 1.70)], &HOLDOUT).is_none()
        );
        // The closest of several; an extension and the entry it extends are not judged here.
        let l = LookAlike::among(
            (CoulombFriction, 1.50),
            [
                (StaticFriction, 1.49),
                (CurrentOffset, 1.52),
                (BridgeDeadtime, 1.51),
            ],
            &HOLDOUT,
        );
        assert_eq!(l.map(|l| l.alike), Some(BridgeDeadtime));
        // A brush drop is a dead time's limit (a vanishing band): chosen, it stands; a dead
        // time chosen over a brush drop that fits as well does not.
        assert!(LookAlike::among((BrushDrop, 1.50), [(BridgeDeadtime, 1.50)], &HOLDOUT).is_none());
        let l = LookAlike::among((BridgeDeadtime, 1.50), [(BrushDrop, 1.50)], &HOLDOUT);
        assert_eq!(l.map(|l| l.alike), Some(BrushDrop));
    }
}

/// An extension the search passed over: it only matches the entry it extends, which was
/// left out ([`Search::needed`]).
#[derive(Clone, Debug)]
pub struct StandingIn {
    /// The effect.
    pub effect: Effect,
    /// The entry it extends, left out.
    pub parent: Effect,
    /// Held-out speed RMSE of the baseline, and with the effect [rad/s].
    pub before: f32,
    /// See `before`.
    pub after: f32,
}

impl Search {
    /// The first effect of the search's chain (named unless the report finds it a partial
    /// stand-in), with the fit of the baseline plus it.
    pub fn chosen(&self) -> Option<&(Effect, Scored)> {
        self.chain.first()
    }

    /// The effect the data needs of `effect` and the one it extends: the parent, unless
    /// `effect`'s fit passes the significance rule against the parent's own fit (a nested
    /// effect that only matches its parent is not named). `None` when the parent was left
    /// out (`--without`) and `effect` only matches it: what `effect` explains is the
    /// parent's part, which may not be named, so neither is.
    pub fn needed(&self, effect: Effect) -> Option<Effect> {
        let Some(parent) = effect.parent() else {
            return Some(effect);
        };
        let fit = |e: Effect| self.fit(e);
        let own_part_shows = |parent_fit: &Scored| {
            fit(effect).is_none_or(|child| {
                let candidate = child.candidate(effect, &self.scales);
                significant(&parent_fit.reference(), &candidate, &self.holdout)
            })
        };
        let left_out = self.left_out_parents.iter().find(|(e, _)| *e == parent);
        match (fit(parent), left_out) {
            (Some(parent_fit), _) if self.significant(parent, parent_fit) => {
                Some(if own_part_shows(parent_fit) {
                    effect
                } else {
                    parent
                })
            }
            (None, Some((_, parent_fit))) => own_part_shows(parent_fit).then_some(effect),
            _ => Some(effect),
        }
    }

    /// The fit of `effect` added to the baseline, when it was scored.
    pub fn fit(&self, effect: Effect) -> Option<&Scored> {
        self.scored
            .iter()
            .find(|(e, _)| *e == effect)
            .map(|(_, s)| s)
    }

    /// The final model: the last effect named, or the baseline.
    pub fn last(&self) -> &Scored {
        self.chain.last().map_or(&self.baseline, |(_, s)| s)
    }

    /// Every effect named, in order, with the fit of the model up to it.
    pub fn named(&self) -> impl Iterator<Item = (Effect, &Scored)> {
        self.chain.iter().map(|(e, s)| (*e, s))
    }

    /// Whether `effect`'s fit passes the significance rule against the baseline.
    pub fn significant(&self, effect: Effect, s: &Scored) -> bool {
        let candidate = s.candidate(effect, &self.scales);
        significant(&self.baseline.reference(), &candidate, &self.holdout)
    }
}
