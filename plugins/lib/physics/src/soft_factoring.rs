//! A soft body's rest system factored anew on a helper thread, off the device tick: after its
//! material or pins change over the bus, the tick hands the helper the new material and pins
//! (in a buffer made at load), goes on solving through the factor it has, and takes the new
//! one when it is ready, handing the old one back to be freed there. The tick only tries to
//! send and receive: it allocates, frees and waits for nothing.

use std::sync::mpsc::{Receiver, SyncSender, TrySendError, sync_channel};

use hapticd_soft::body::SoftBody;
use hapticd_soft::factor::Factor;
use hapticd_soft::implicit::Solver;

/// What the helper is asked to factor: the body's material's Young's modulus, Poisson's
/// ratio and damping, its pins, and the step factor.
struct Ask {
    material: [f64; 3],
    pins: Vec<bool>,
    stiff: f64,
}

/// The tick's end of a helper thread that factors one soft body's rest system.
#[derive(Debug)]
pub struct Factoring {
    asks: SyncSender<Ask>,
    made: Receiver<(Option<Factor>, Vec<bool>)>,
    spent: SyncSender<Option<Factor>>,
    /// The buffer the next ask carries its pins in (empty while the helper has it).
    pins: Vec<bool>,
    /// Whether an ask is out.
    asked: bool,
}

impl Factoring {
    /// A helper for `body` (copied: its mesh and masses are what a factor is made of),
    /// named after the body `name`; None if no thread can be started.
    pub fn start(name: &str, body: &SoftBody) -> Option<Factoring> {
        let (asks, asked) = sync_channel::<Ask>(1);
        let (done, made) = sync_channel(1);
        let (spent, freed) = sync_channel::<Option<Factor>>(1);
        let mut own = body.clone();
        let pins = vec![false; body.pinned.len()];
        std::thread::Builder::new()
            .name(format!("factor {name}"))
            .spawn(move || {
                while let Ok(ask) = asked.recv() {
                    let [young, poisson, damping] = ask.material;
                    own.set_material(young, poisson, damping);
                    own.pinned.copy_from_slice(&ask.pins);
                    // The pins' buffer goes back whether a factor could be made or not.
                    let factor = Factor::new(&own, ask.stiff).ok();
                    let made = factor.is_some();
                    if done.send((factor, ask.pins)).is_err() {
                        return;
                    }
                    // The factor it replaced, freed here.
                    if made && freed.recv().is_err() {
                        return;
                    }
                }
            })
            .ok()?;
        Some(Factoring {
            asks,
            made,
            spent,
            pins,
            asked: false,
        })
    }

    /// [rt] Ask for `body`'s rest system factored for steps of factor `stiff`, unless an ask
    /// is out; whether it was asked.
    pub fn ask(&mut self, body: &SoftBody, stiff: f64) -> bool {
        if self.asked {
            return false;
        }
        self.pins.copy_from_slice(&body.pinned);
        let m = &body.material;
        let ask = Ask {
            material: [m.young, m.poisson, m.damping],
            pins: std::mem::take(&mut self.pins),
            stiff,
        };
        match self.asks.try_send(ask) {
            Ok(()) => self.asked = true,
            Err(TrySendError::Full(ask) | TrySendError::Disconnected(ask)) => self.pins = ask.pins,
        }
        self.asked
    }

    /// [rt] Put a factor the helper has made into `solver`, the one it had sent back to be
    /// freed (none when the system could not be factored: the solve goes on as it was).
    pub fn take(&mut self, solver: &mut Solver) {
        let Ok((factor, pins)) = self.made.try_recv() else {
            return;
        };
        self.pins = pins;
        self.asked = false;
        if let Some(factor) = factor {
            let old = solver.swap_factor(factor);
            // The helper waits for it: the channel has room.
            let _ = self.spent.try_send(old);
        }
    }
}

/// A soft body's helper, if it has one: a copy of the body has none (its helper stays
/// with the original).
#[derive(Debug, Default)]
pub struct Aside(pub Option<Factoring>);

impl Clone for Aside {
    fn clone(&self) -> Self {
        Aside(None)
    }
}
