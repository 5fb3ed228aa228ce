//! The local [`Runner`]: a pool of worker threads, each with its own clone of the simulator.

use super::{simulate, Done, Runner, Task};
use crate::CampaignError;
use crossbeam_channel::{Receiver, Sender};
use savme_kernel::Simulator;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Worker threads, each with its own simulator.
pub struct Pool {
    tasks: Sender<Task>,
    done: Receiver<Done>,
}

impl Runner for Pool {
    fn submit(&mut self, task: Task) -> Result<(), CampaignError> {
        self.tasks
            .send(task)
            .map_err(|_| CampaignError::WorkersGone)
    }

    fn next_done(&mut self) -> Result<Done, CampaignError> {
        self.done.recv().map_err(|_| CampaignError::WorkersGone)
    }
}

/// Starts `jobs` workers, each with a clone of `sim`, runs `f` with the pool, and stops the
/// workers (dropping queued tasks) when `f` returns.
pub fn with_pool<S, R>(sim: &S, jobs: usize, f: impl FnOnce(&mut Pool) -> R) -> R
where
    S: Simulator + Clone + Send,
{
    let (task_tx, task_rx) = crossbeam_channel::unbounded::<Task>();
    let (done_tx, done_rx) = crossbeam_channel::unbounded::<Done>();
    let stop = Arc::new(AtomicBool::new(false));
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1) {
            let (rx, tx, stop) = (task_rx.clone(), done_tx.clone(), stop.clone());
            let mut sim = sim.clone();
            scope.spawn(move || {
                for t in rx {
                    if stop.load(Ordering::Relaxed) {
                        break;
                    }
                    let result = simulate(&mut sim, t.which, &t.scenario, &t.phi, &t.fidelity);
                    let done = Done {
                        trial: t.trial,
                        which: t.which,
                        result,
                    };
                    if tx.send(done).is_err() {
                        break;
                    }
                }
            });
        }
        drop(done_tx);
        drop(task_rx);
        let mut pool = Pool {
            tasks: task_tx,
            done: done_rx,
        };
        let r = f(&mut pool);
        stop.store(true, Ordering::Relaxed);
        drop(pool);
        r
    })
}
