//! Changes of one body from several hosts, made into one. Each host moves the bodies near
//! its grips itself (local dynamics) from the world as it last saw it, a round trip ago, and
//! hands back how far its hand moved them. Two fingers pushing one block each move it the
//! whole way with their own finger; summed, the block would go twice as far, and each host,
//! not yet seeing the other's push, would push again for as long as the round trip: the
//! block gains energy neither hand gave it. So a change is taken in only for what the other
//! hosts' changes taken in since its host's view do not already do: along each axis, a push
//! the same way as theirs adds only what goes beyond them; a push against them, or across,
//! adds whole.

use std::collections::VecDeque;

use hapticd_plugin_api::HapticdLocalState;

/// Steps a change is remembered for (a second at 60 steps a second: longer than any round
/// trip a hand is rendered across).
const REMEMBERED_STEPS: u64 = 64;

/// A change as the world took it in.
#[derive(Debug, Clone, Copy)]
struct Entry {
    /// The step it was taken into.
    step: u64,
    host: u64,
    body: u32,
    change: [f64; 12],
}

fn components(change: &HapticdLocalState) -> [f64; 12] {
    let mut out = [0.0; 12];
    for (k, v) in [
        change.displacement,
        change.rotation,
        change.velocity,
        change.spin,
    ]
    .iter()
    .enumerate()
    {
        out[3 * k..3 * k + 3].copy_from_slice(v);
    }
    out
}

/// The changes taken in over the last steps.
#[derive(Debug, Default)]
pub struct Ledger {
    entries: VecDeque<Entry>,
}

impl Ledger {
    /// What of host `host`'s `change`, computed on the world of step `base`, to take into
    /// step `step`: the change less what other hosts' changes of its body taken in after
    /// `base` already do along each axis. Recorded as taken in.
    pub fn reconcile(
        &mut self,
        host: u64,
        base: u64,
        step: u64,
        change: &HapticdLocalState,
    ) -> HapticdLocalState {
        let mut unseen = [0.0; 12];
        for e in self
            .entries
            .iter()
            .filter(|e| e.body == change.body && e.host != host && e.step > base)
        {
            for (u, c) in unseen.iter_mut().zip(e.change) {
                *u += c;
            }
        }
        let mut taken = components(change);
        for (t, u) in taken.iter_mut().zip(unseen) {
            if *t * u > 0.0 {
                *t = t.signum() * (t.abs() - u.abs()).max(0.0);
            }
        }
        self.entries.push_back(Entry {
            step,
            host,
            body: change.body,
            change: taken,
        });
        while self
            .entries
            .front()
            .is_some_and(|e| e.step + REMEMBERED_STEPS < step)
        {
            self.entries.pop_front();
        }
        let part = |k: usize| [taken[3 * k], taken[3 * k + 1], taken[3 * k + 2]];
        HapticdLocalState {
            displacement: part(0),
            rotation: part(1),
            velocity: part(2),
            spin: part(3),
            ..*change
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn push(body: u32, dx: f64, vz: f64) -> HapticdLocalState {
        HapticdLocalState {
            body,
            sequence: 1,
            displacement: [dx, 0.0, 0.0],
            velocity: [0.0, 0.0, vz],
            ..HapticdLocalState::default()
        }
    }

    #[test]
    fn two_hosts_pushing_one_way_on_the_same_view_move_the_body_once() {
        let mut ledger = Ledger::default();
        let a = ledger.reconcile(1, 10, 11, &push(0, 0.002, 0.0));
        assert_eq!(a.displacement[0], 0.002, "the first is taken whole");
        // The second host saw step 10 too: of its 3 mm, the 2 mm already done are not again.
        let b = ledger.reconcile(2, 10, 12, &push(0, 0.003, 0.0));
        assert!((b.displacement[0] - 0.001).abs() < 1e-15, "{b:?}");
        // Once it has seen the first host's push (step 11 on), its pushes count whole.
        let c = ledger.reconcile(2, 12, 13, &push(0, 0.002, 0.0));
        assert_eq!(c.displacement[0], 0.002);
        // Its own changes never shorten a host's next one.
        let d = ledger.reconcile(1, 10, 13, &push(0, 0.002, 0.0));
        assert!(
            (d.displacement[0] - 0.0).abs() < 1e-15,
            "host 2's 3 mm since step 10: {d:?}"
        );
    }

    #[test]
    fn pushes_against_or_across_each_other_and_on_other_bodies_add_whole() {
        let mut ledger = Ledger::default();
        ledger.reconcile(1, 5, 6, &push(0, 0.002, 0.1));
        let against = ledger.reconcile(2, 5, 6, &push(0, -0.002, 0.0));
        assert_eq!(against.displacement[0], -0.002);
        let across = ledger.reconcile(3, 5, 6, &push(0, 0.0, -0.05));
        assert_eq!(across.velocity[2], -0.05);
        let other = ledger.reconcile(2, 5, 6, &push(1, 0.002, 0.0));
        assert_eq!(other.displacement[0], 0.002);
        assert_eq!((other.body, other.sequence), (1, 1), "the rest as sent");
    }

    #[test]
    fn old_changes_are_forgotten() {
        let mut ledger = Ledger::default();
        ledger.reconcile(1, 0, 1, &push(0, 0.002, 0.0));
        for step in 2..200 {
            ledger.reconcile(1, step - 1, step, &push(5, 0.0, 0.0));
        }
        assert!(ledger.entries.len() <= REMEMBERED_STEPS as usize + 1);
        assert_eq!(
            ledger
                .reconcile(2, 0, 200, &push(0, 0.002, 0.0))
                .displacement[0],
            0.002
        );
    }
}
