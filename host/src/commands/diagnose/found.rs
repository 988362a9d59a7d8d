//! What the search over the catalogue found ([`super::search`]): the baseline, every
//! effect scored against it, the chain of effects named and the stand-ins passed over, and
//! the questions the report asks of them (the first effect, the final model, whether an
//! effect is significant, which of an extension and its parent the data needs).

use super::data::Scored;
use super::regimes::WhereReport;
use super::verdict::{significant, Holdout};
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
