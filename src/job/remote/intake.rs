//! The coordinator's intake of a job's range results (issue 40): decoded and added up
//! as they arrive, on the NATS runtime's blocking threads, so that the scheduler
//! thread only adds one finished group of ranges at a time.
//!
//! A job publishes its units in groups of consecutive ranges, a group about as many
//! units as the pool has workers. Exact sums add in any order and grouping with the
//! same result (`film::exact`), so the ranges of a group are added to each other as
//! they come, in whatever order, by whichever thread decoded them: a thread that has
//! decoded a range takes any partial sum left by another thread, adds the two, and
//! repeats until none is left, then leaves its own. Additions of one group therefore
//! run on as many threads as decode at once, and a group holds at most that many
//! partial sums. Once all of a group's iterations are in, the scheduler adds the
//! group to the job's sums in index order, as before: one addition per group instead
//! of one per range, and the image is the same bit for bit.

use super::Done;
use crate::film::ExactSums;
use crate::integrator::RenderStats;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// What a job's range results must be: exact sums of the film's size holding at most
/// `images` images (anything else is refused before it is unpacked).
#[derive(Clone, Copy, Debug)]
pub struct Expected {
    pub size: (u32, u32),
    pub images: usize,
}

/// One job's groups of ranges, from one start of its stream of units.
pub struct Intake {
    pub generation: u64,
    expect: Expected,
    /// Open groups by first iteration.
    groups: Mutex<BTreeMap<u64, Arc<Group>>>,
}

struct Group {
    end: u64,
    state: Mutex<GroupState>,
}

#[derive(Default)]
struct GroupState {
    /// First iterations of the ranges taken (decoding or added): a second copy of a
    /// range (a worker died after storing it) is dropped.
    taken: BTreeSet<u64>,
    /// Iterations added to `partials`.
    added: u64,
    partials: Vec<ExactSums>,
    stats: RenderStats,
}

/// What became of a range result offered to [`Intake::fold`].
#[derive(Debug, PartialEq, Eq)]
pub enum Filed {
    /// Added to its group.
    Added,
    /// Of another generation, already added, or a second copy: nothing to do.
    Dropped,
    /// Not exact sums of the job's film: the range must be rendered again.
    Damaged,
}

/// A group whose ranges are all in, ready to extend the job's sums.
pub struct Complete {
    pub end: u64,
    pub sums: ExactSums,
    pub stats: RenderStats,
}

impl Intake {
    pub fn new(generation: u64, expect: Expected) -> Intake {
        Intake {
            generation,
            expect,
            groups: Mutex::new(BTreeMap::new()),
        }
    }

    /// Opens the group of iterations `first..end` (before its units are published).
    pub fn open(&self, first: u64, end: u64) {
        let group = Group {
            end,
            state: Mutex::new(GroupState::default()),
        };
        self.lock().insert(first, Arc::new(group));
    }

    /// Groups open (published and not yet taken by [`Intake::take`]).
    pub fn open_groups(&self) -> usize {
        self.lock().len()
    }

    /// Decodes the result `bytes` of the range `done` names and adds it to its group,
    /// on the calling thread.
    pub fn fold(&self, done: &Done, bytes: &[u8]) -> Filed {
        let Some(group) = self.group_of(done) else {
            return Filed::Dropped;
        };
        if !group.state().taken.insert(done.first) {
            return Filed::Dropped;
        }
        let started = Instant::now();
        let decoded = ExactSums::decode_expected(bytes, self.expect.size, self.expect.images);
        let Ok(mut mine) = decoded else {
            group.state().taken.remove(&done.first);
            return Filed::Damaged;
        };
        let decode_s = started.elapsed().as_secs_f64();
        let started = Instant::now();
        loop {
            let other = {
                let mut s = group.state();
                match s.partials.pop() {
                    Some(p) => p,
                    None => {
                        s.partials.push(mine);
                        s.added += done.end - done.first;
                        s.stats += done.stats;
                        break;
                    }
                }
            };
            // Same film and job: the sizes agree, so the addition cannot fail.
            if mine.merge(&other).is_err() {
                tracing::error!("ranges of one job disagree in size");
            }
        }
        // The per-range cost of the coordinator, for the scaling model (README).
        tracing::debug!(job = %done.job, decode_s, fold_s = started.elapsed().as_secs_f64(), bytes = bytes.len(), "range added to its group");
        Filed::Added
    }

    /// The group starting at `first`, removed, if all its ranges are in.
    pub fn take(&self, first: u64) -> Option<Complete> {
        let mut groups = self.lock();
        let group = groups.get(&first)?;
        let complete = {
            let s = group.state();
            s.added == group.end - first
        };
        if !complete {
            return None;
        }
        let group = groups.remove(&first)?;
        drop(groups);
        let mut s = std::mem::take(&mut *group.state());
        let mut sums = s.partials.pop()?;
        for p in &s.partials {
            if sums.merge(p).is_err() {
                tracing::error!("ranges of one job disagree in size");
            }
        }
        Some(Complete {
            end: group.end,
            sums,
            stats: s.stats,
        })
    }

    /// The open group holding range `done`, if it is of this generation.
    fn group_of(&self, done: &Done) -> Option<Arc<Group>> {
        if done.generation != self.generation {
            return None;
        }
        let groups = self.lock();
        let (_, group) = groups.range(..=done.first).next_back()?;
        (done.end <= group.end).then(|| group.clone())
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, BTreeMap<u64, Arc<Group>>> {
        self.groups.lock().expect("intake")
    }
}

impl Group {
    fn state(&self) -> std::sync::MutexGuard<'_, GroupState> {
        self.state.lock().expect("group")
    }
}

/// The intakes of the jobs a coordinator runs on its pool, by job id.
#[derive(Default)]
pub struct Intakes(Mutex<HashMap<String, Arc<Intake>>>);

impl Intakes {
    pub fn insert(&self, job: &str, intake: Arc<Intake>) {
        self.0.lock().expect("intakes").insert(job.into(), intake);
    }

    /// Removes the job's intake if it is of `generation` (a newer one stays).
    pub fn remove(&self, job: &str, generation: u64) {
        let mut map = self.0.lock().expect("intakes");
        if map.get(job).is_some_and(|i| i.generation == generation) {
            map.remove(job);
        }
    }

    pub fn get(&self, job: &str) -> Option<Arc<Intake>> {
        self.0.lock().expect("intakes").get(job).cloned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Film;

    const SIZE: (u32, u32) = (24, 16);

    /// The exact sums of iterations `first..end` of a made-up render.
    fn range(first: u64, end: u64) -> ExactSums {
        let mut sums = ExactSums::new(SIZE.0, SIZE.1);
        for i in first..end {
            let mut film = Film::new(SIZE.0, SIZE.1);
            for (p, v) in film.sums_mut().iter_mut().enumerate() {
                let x = ((p as u64 * 2654435761 + i * 7919) % 1013) as f64 / 97.0;
                *v = [x, x.sqrt(), 1.0 / (1.0 + x)];
            }
            sums.add_iteration(&film).unwrap();
        }
        sums
    }

    fn done(generation: u64, first: u64, end: u64) -> Done {
        Done {
            job: "j".into(),
            generation,
            first,
            end,
            worker: "w".into(),
            object: Some("o".into()),
            error: None,
            stats: RenderStats {
                samples: end - first,
                ..Default::default()
            },
            seconds: 1.0,
        }
    }

    fn intake() -> Intake {
        Intake::new(
            7,
            Expected {
                size: SIZE,
                images: 2,
            },
        )
    }

    #[test]
    fn a_group_added_up_on_many_threads_in_any_order_equals_its_ranges_in_order() {
        let units: Vec<(u64, u64)> = (0..12).map(|k| (3 * k, 3 * k + 3)).collect();
        let mut in_order = ExactSums::new(SIZE.0, SIZE.1);
        for &(a, b) in &units {
            in_order.merge(&range(a, b)).unwrap();
        }
        let intake = intake();
        intake.open(0, 36);
        let results: Vec<(Done, Vec<u8>)> = units
            .iter()
            .rev()
            .map(|&(a, b)| (done(7, a, b), range(a, b).encode_packed()))
            .collect();
        std::thread::scope(|s| {
            for chunk in results.chunks(3) {
                let intake = &intake;
                s.spawn(move || {
                    for (d, bytes) in chunk {
                        assert_eq!(intake.fold(d, bytes), Filed::Added);
                    }
                });
            }
        });
        let group = intake.take(0).expect("complete");
        assert_eq!(group.end, 36);
        assert_eq!(group.sums, in_order);
        assert_eq!(group.stats.samples, 36);
        assert_eq!(intake.open_groups(), 0);
    }

    #[test]
    fn a_group_is_taken_only_once_all_its_ranges_are_in() {
        let intake = intake();
        intake.open(0, 4);
        intake.open(4, 8);
        let add = |a, b| intake.fold(&done(7, a, b), &range(a, b).encode());
        assert_eq!(add(4, 8), Filed::Added);
        assert!(
            intake.take(4).is_some(),
            "a group may finish before the one before it"
        );
        assert_eq!(add(0, 2), Filed::Added);
        assert!(intake.take(0).is_none());
        assert_eq!(add(0, 2), Filed::Dropped, "a second copy of a range");
        assert_eq!(
            add(4, 8),
            Filed::Dropped,
            "a range of a group already taken"
        );
        let other_generation = intake.fold(&done(8, 2, 4), &range(2, 4).encode());
        assert_eq!(other_generation, Filed::Dropped);
        assert!(intake.take(0).is_none());
        assert_eq!(add(2, 4), Filed::Added);
        let group = intake.take(0).expect("complete");
        assert_eq!(group.sums, range(0, 4));
    }

    #[test]
    fn a_damaged_result_is_refused_and_its_range_can_come_again() {
        let intake = intake();
        intake.open(0, 2);
        let d = done(7, 0, 2);
        let good = range(0, 2).encode_packed();
        assert_eq!(intake.fold(&d, &good[..good.len() / 2]), Filed::Damaged);
        let wrong_size = ExactSums::new(SIZE.1, SIZE.0).encode();
        assert_eq!(intake.fold(&d, &wrong_size), Filed::Damaged);
        assert!(intake.take(0).is_none());
        assert_eq!(intake.fold(&d, &good), Filed::Added);
        assert_eq!(intake.take(0).expect("complete").sums, range(0, 2));
    }
}
