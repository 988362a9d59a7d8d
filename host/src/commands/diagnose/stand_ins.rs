//! Which effects of the search are partial stand-ins and which stay named: the rules of
//! [`super::naming`] and the look-alikes of [`super::found::LookAlike`] applied to the
//! final model, for the report ([`super::report`]).

use super::found::Search;
use super::naming::{
    stand_in_reason, stand_ins, unpinned_own, Channel, MisfitWhereItActs, PartialStandIn,
};
use crate::report::Num;
use motor_id_shared::model::effects::Effect;

/// The search's effects judged: the partial stand-ins, and which effects stay named.
pub struct Judged {
    /// Every partial stand-in, in the order the report lists them.
    pub partial: Vec<PartialStandIn>,
    /// Effects of the final model that are stand-ins while the others stay named.
    pub loose: Vec<Effect>,
    /// False when the effects together leave most of a channel's excess: none is named.
    named: bool,
}

impl Judged {
    /// Whether `effect` of the search's chain is named.
    pub fn names(&self, effect: Effect) -> bool {
        self.named && !self.loose.contains(&effect)
    }

    /// The effects of `search` judged on its final model: `channels` (speed, then the
    /// current when measured; `with_current`), the named effects whose own regime keeps the
    /// misfit (`where_it_acts`).
    pub fn of(
        search: &Search,
        with_current: bool,
        channels: &[Channel],
        where_it_acts: &[MisfitWhereItActs],
    ) -> Judged {
        let stand_in = stand_in_reason(channels);
        let mut partial = match &stand_in {
            Some((why, k)) => {
                let (names, steps): (Vec<&'static str>, Vec<f32>) = search
                    .named()
                    .map(|(e, s)| {
                        let current = s.holdout_rmse_current.unwrap_or(f32::NAN);
                        (e.name(), if *k == 0 { s.holdout_rmse } else { current })
                    })
                    .unzip();
                stand_ins(&names, &steps, &channels[*k], why)
            }
            None => Vec::new(),
        };
        // An extension that only matches the entry it extends, left out by the user: a
        // stand-in for that entry (found::Search::needed).
        for x in &search.standing_in {
            partial.push(PartialStandIn {
                name: x.effect.name(),
                share_of_excess: Num(channels[0].share(x.before, x.after)),
                channel: channels[0].name,
                why: format!(
                    "no better on the held-out records than {}, which it extends and which was left out: what it explains is that entry's part, not its own",
                    x.parent.name()
                ),
                in_model: false,
            });
        }
        // A named effect of the final model is a stand-in too, the others staying named,
        // when its fit does not pin its own parameters (naming::unpinned_own), its own
        // regime keeps the misfit (naming::misfit_where_it_acts) or an entry of another
        // form fitted as well where the search added it (found::LookAlike). The first needs current:
        // from the speed alone the motor has flat directions (paper Eq. 6) along which a
        // torque-like parameter scales too (Coulomb friction's tc with J and B), so it is
        // unpinned whatever the records show of its form.
        let final_fit = &search.last().fit.result.identifiability;
        let mut loose: Vec<Effect> = Vec::new();
        if stand_in.is_none() {
            let (effects, steps): (Vec<Effect>, Vec<f32>) =
                search.named().map(|(e, s)| (e, s.holdout_rmse)).unzip();
            let names: Vec<&'static str> = effects.iter().map(|e| e.name()).collect();
            let each = stand_ins(&names, &steps, &channels[0], "");
            // Those with unpinned parameters listed first, then those whose form does not
            // fit (the regime rule) or is not told apart (the look-alikes).
            let (mut by_params, mut by_form) = (Vec::new(), Vec::new());
            for (e, mut p) in effects.into_iter().zip(each) {
                let free = match with_current {
                    true => unpinned_own(e, final_fit),
                    false => Vec::new(),
                };
                if !free.is_empty() {
                    p.why = format!(
                        "the records do not pin its {}: they do not show its form, only that it shaves the misfit",
                        free.join(", ")
                    );
                    by_params.push(p);
                } else if let Some(w) = where_it_acts.iter().find(|w| w.effect == e) {
                    p.why = w.why();
                    by_form.push(p);
                } else if let Some(l) = search.look_alikes.iter().find(|l| l.effect == e) {
                    p.why = l.why();
                    by_form.push(p);
                } else {
                    continue;
                }
                loose.push(e);
            }
            partial.extend(by_params);
            partial.extend(by_form);
        }
        Judged {
            partial,
            loose,
            named: stand_in.is_none(),
        }
    }
}
