//! Projection attempts computed ahead, over threads, with the same result as one at a time.
//!
//! An attempt (a uniform draw of the joint readings, the tracking-noise target, the Newton
//! projection) reads the pose stream only for its draws, a fixed count per constraint kind,
//! and its projection is a pure function of them. So a batch of the attempts the sequential
//! run would make next can be drawn in order (the stream's state kept before and after each)
//! and projected in parallel. The batch assumes every attempt lands (attempt `t` on the
//! constraint of pose `l + t`); when the run needs an attempt on another constraint than the
//! next one queued (one failed, on a list of constraints), the stream is rewound to that
//! attempt's state and the rest of the batch dropped. Nothing else may read the stream
//! between attempts (no encoder or measurement noise, no measured constraint): the caller
//! checks that before using a [`Batch`].

use std::collections::VecDeque;

use rand_chacha::ChaCha8Rng;

use super::project::Projector;

/// Attempts per thread in one batch.
const PER_THREAD: usize = 64;

/// One attempt computed ahead: its constraint, the stream before and after its draws, and
/// the projected pose (`None`: it failed).
struct Attempt {
    constraint: usize,
    before: ChaCha8Rng,
    after: ChaCha8Rng,
    pose: Option<Vec<f64>>,
}

/// An attempt drawn but not yet projected: its constraint, the stream before and after its
/// draws, the joint readings drawn and the target offset.
type Job = (usize, ChaCha8Rng, ChaCha8Rng, Vec<f64>, Vec<f64>);

/// The queue of attempts computed ahead.
pub(crate) struct Batch {
    queue: VecDeque<Attempt>,
    threads: usize,
    /// Attempts in the next batch: halved (down to one per thread) when a batch is cut short,
    /// doubled (up to [`PER_THREAD`] per thread) when one is used up, so a list of
    /// constraints where attempts often fail wastes little.
    size: usize,
}

impl Batch {
    /// An empty queue projecting over the machine's threads (at most 8).
    pub(crate) fn new() -> Self {
        let threads = std::thread::available_parallelism()
            .map_or(1, std::num::NonZeroUsize::get)
            .clamp(1, 8);
        Batch {
            queue: VecDeque::new(),
            threads,
            size: PER_THREAD * threads,
        }
    }

    /// The next attempt on constraint `j` for pose `l` (of constraints used in turn,
    /// `count` of them), as the sequential run would make it from `rng`: its projected pose
    /// or `None`; `rng` is left after the attempt's draws.
    pub(crate) fn next(
        &mut self,
        proj: &Projector<'_>,
        rng: &mut ChaCha8Rng,
        (l, j, count): (usize, usize, usize),
        draw_target: impl Fn(&mut ChaCha8Rng, usize) -> Vec<f64>,
    ) -> Option<Vec<f64>> {
        if self.queue.front().is_some_and(|a| a.constraint != j) {
            if let Some(a) = self.queue.front() {
                *rng = a.before.clone();
            }
            self.queue.clear();
            self.size = (self.size / 2).max(self.threads);
        } else if self.queue.is_empty() {
            self.size = (self.size * 2).min(PER_THREAD * self.threads);
        }
        if self.queue.is_empty() {
            self.fill(proj, rng, l, count, &draw_target);
        }
        let a = self.queue.pop_front()?;
        *rng = a.after;
        a.pose
    }

    /// Draws the attempts for poses `l, l + 1, …` (each assumed to land) and projects them
    /// over threads.
    fn fill(
        &mut self,
        proj: &Projector<'_>,
        rng: &mut ChaCha8Rng,
        l: usize,
        count: usize,
        draw_target: &impl Fn(&mut ChaCha8Rng, usize) -> Vec<f64>,
    ) {
        let size = self.size;
        let mut jobs = Vec::with_capacity(size);
        for t in 0..size {
            let j = (l + t) % count.max(1);
            let before = rng.clone();
            let q0 = proj.draw(rng);
            let target = draw_target(rng, j);
            jobs.push((j, before, rng.clone(), q0, target));
        }
        let project = |part: &[Job]| {
            part.iter()
                .map(|(j, _, _, q0, target)| proj.project(*j, q0.clone(), target))
                .collect::<Vec<_>>()
        };
        // One chunk (no thread) when `threads` is 1.
        let per = size.div_ceil(self.threads.max(1));
        let poses: Vec<Option<Vec<f64>>> = crate::numeric::par_chunks(&jobs, per, project);
        for ((constraint, before, after, _, _), pose) in jobs.into_iter().zip(poses) {
            self.queue.push_back(Attempt {
                constraint,
                before,
                after,
                pose,
            });
        }
    }
}
