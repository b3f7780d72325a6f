//! Issue 49's reverse curriculum (`[curriculum]`): a share of the training episodes begins
//! on one of a teacher's scoring episodes, a few agent steps before its goal at first and
//! further back as the run goes on, until it begins at the teacher's own start (Salimans
//! and Chen's "learning from a single demonstration", with many). The learner practises
//! the last, millisecond-exact part of a goal where it is short, and earns the goal's
//! reward there before it can find it from the kick-off.
//!
//! The starts move back on a clock (`schedule = "clock"`: linearly with the run's env
//! steps) or as the learner succeeds (`schedule = "success"`, Salimans and Chen's rule): a
//! [`SuccessSchedule`] judges the learner's teacher-begun episodes in windows and moves
//! every env's starts back when it scored in enough of them. Its state (how far back, the
//! window so far) is the training loop's, written in the checkpoint, and changes only
//! between vector steps: the envs read the same distance whatever the thread count.
//!
//! The teacher's files are read once per run: every episode that scores is kept up to the
//! step that puts the ball in the goal, and played again on a table of the run's game to
//! check that it still scores there at that step (a file of another game is refused,
//! naming it). Each training env gets a [`TeacherStarts`] ([`foosball_env::starts`]),
//! whose random stream restarts from each seeded reset of its env: a resumed run chooses
//! as the uninterrupted one.

use crate::config::{CurriculumConfig, CurriculumSchedule, RunConfig};
use crate::play::evaluation::foosball_envs;
use crate::run::demonstrations::{learnable_episodes, names};
use foosball_algos::Metrics;
use foosball_env::layout::{ACTION_DIM, OBS_DIM};
use foosball_env::seeding::{CURRICULUM, derive_seed};
use foosball_env::starts::{EpisodeStarts, ReplayStart};
use foosball_env::{Env, FoosballEnv, FoosballInfo, ball_in_a_goal};
use foosball_nets::{Snapshot, SnapshotError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};

/// One of the teacher's scoring episodes, up to its goal.
#[derive(Clone, Debug, PartialEq)]
pub struct TeacherEpisode {
    /// The seed it was reset with.
    pub seed: u64,
    /// Its actions up to the one that put the ball in the goal, `goal_step` of them.
    pub actions: Vec<[f32; ACTION_DIM]>,
}

impl TeacherEpisode {
    /// Agent steps from its start to the goal.
    pub fn goal_step(&self) -> usize {
        self.actions.len()
    }
}

/// The scoring episodes of the files `c.trajectories`, each cut at its goal, checked to
/// score at that step on `config`'s table. A refusal names the key and the file.
pub fn teacher_episodes(
    config: &RunConfig,
    c: &CurriculumConfig,
) -> Result<Vec<TeacherEpisode>, String> {
    let key = "curriculum.trajectories";
    // One table replays every episode (each reset from its seed builds the episode anew).
    let mut env = FoosballEnv::new(config.env.clone()).map_err(|e| format!("env.{e}"))?;
    let mut kept = Vec::new();
    for (path, k, e) in learnable_episodes(config, key, c.trajectories.paths())? {
        let refuse = |why: String| format!("{key} = \"{path}\": {why}");
        let t = &e.trajectory;
        let steps = t.rewards.len();
        if t.obs.len() != steps * OBS_DIM || t.actions.len() != steps * ACTION_DIM {
            return Err(refuse(format!(
                "episode {k} holds {} state and {} action values for {steps} steps, not \
                 {OBS_DIM} and {ACTION_DIM} per step",
                t.obs.len(),
                t.actions.len()
            )));
        }
        // Row `s` is the state acted on at step `s`: a ball seen in the goal there
        // went in during step `s - 1`.
        let goal = t
            .obs
            .chunks_exact(OBS_DIM)
            .position(|s| ball_in_a_goal(&config.env, s));
        if let Some(goal) = goal.filter(|&g| g > 0) {
            let actions = t.actions[..goal * ACTION_DIM]
                .chunks_exact(ACTION_DIM)
                .map(|a| a.try_into().expect("a full row"))
                .collect();
            let episode = TeacherEpisode {
                seed: e.seed,
                actions,
            };
            check_replay(&mut env, config, &episode)
                .map_err(|why| refuse(format!("episode {k}: {why}")))?;
            kept.push(episode);
        }
    }
    if kept.is_empty() {
        return Err(format!(
            "{key} = {}: no episode scores; the curriculum begins along scoring ones",
            names(c.trajectories.paths())
        ));
    }
    Ok(kept)
}

/// Whether `episode` still scores at its goal step when played again on `env`, a table of
/// `config`'s game.
fn check_replay(
    env: &mut FoosballEnv,
    config: &RunConfig,
    episode: &TeacherEpisode,
) -> Result<(), String> {
    env.reset(Some(episode.seed));
    for (s, action) in episode.actions.iter().enumerate() {
        let (_, t) = env.step(action).map_err(|e| e.to_string())?;
        let last = s + 1 == episode.goal_step();
        if t.done() && !last {
            return Err(format!(
                "played again on this run's table it ends at step {} of the {} to its goal: \
                 recorded on another game or against another opponent?",
                s + 1,
                episode.goal_step()
            ));
        }
    }
    let state = env.state().expect("a reset env has a state");
    if ball_in_a_goal(&config.env, state) {
        Ok(())
    } else {
        Err(format!(
            "played again on this run's table its ball is not in the goal after the {} \
             steps it took to score: recorded on another game or against another opponent?",
            episode.goal_step()
        ))
    }
}

/// Agent steps before its goal where a teacher's episode is begun, `progress` (a fraction)
/// into the run: `first_back` at 0, growing linearly to `goal_step` (the teacher's start)
/// at `whole_at`, never before the start.
pub fn steps_back(c: &CurriculumConfig, goal_step: usize, progress: f64) -> usize {
    let first = (c.first_back as usize).min(goal_step);
    let grown = (goal_step - first) as f64 * (progress / c.whole_at).clamp(0.0, 1.0);
    first + grown.round() as usize
}

/// What a checkpoint keeps of a [`SuccessSchedule`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CurriculumState {
    /// Agent steps before the teacher's goals where its episodes begin.
    pub back: u32,
    /// Whether the learner scored, per teacher-begun episode of the window so far.
    pub window: Vec<bool>,
}

impl CurriculumState {
    /// Stores the state under `curriculum.*`.
    pub fn save(&self, snap: &mut Snapshot<'_>) {
        snap.put_u64("curriculum.back", u64::from(self.back));
        snap.put_bools("curriculum.window", &self.window);
    }

    /// The state stored by [`Self::save`]; `None` in a checkpoint without one.
    pub fn load(snap: &Snapshot<'_>) -> Result<Option<Self>, SnapshotError> {
        if !snap.contains("curriculum.back") {
            return Ok(None);
        }
        Ok(Some(Self {
            back: u32::try_from(snap.u64("curriculum.back")?).unwrap_or(u32::MAX),
            window: snap.bools("curriculum.window")?,
        }))
    }
}

/// `schedule = "success"`: how far back the teacher's episodes begin, moved by the
/// learner's outcomes from there. Shared by the run's training envs ([`training_envs`]),
/// changed by the training loop between vector steps ([`Self::on_episode`]).
pub struct SuccessSchedule {
    config: CurriculumConfig,
    back: Arc<AtomicU32>,
    window: Vec<bool>,
    /// The teacher's longest episode, agent steps: starts never move further back.
    longest: u32,
}

impl SuccessSchedule {
    /// The schedule of `config`'s `[curriculum]` when it is `"success"`, from a
    /// checkpoint's `state` or from `first_back`; `None` otherwise.
    pub fn start(
        config: &RunConfig,
        teacher: Option<&Arc<Vec<TeacherEpisode>>>,
        state: Option<CurriculumState>,
    ) -> Option<Self> {
        let c = config.curriculum.as_ref()?;
        let teacher = teacher?;
        if c.schedule != CurriculumSchedule::Success {
            return None;
        }
        let longest = teacher.iter().map(|e| e.goal_step()).max().unwrap_or(0) as u32;
        let state = state.unwrap_or(CurriculumState {
            back: c.first_back.min(longest),
            window: Vec::new(),
        });
        Some(Self {
            config: c.clone(),
            back: Arc::new(AtomicU32::new(state.back)),
            window: state.window,
            longest,
        })
    }

    /// Agent steps before the teacher's goals where its episodes begin now.
    pub fn back(&self) -> u32 {
        self.back.load(Ordering::Relaxed)
    }

    /// Counts an episode's end (`info` of its last step): one begun on the teacher's joins
    /// the window, and a full window moves the starts back by `advance` when the learner
    /// scored in at least `success_rate` of it. Returns the episode's row of training
    /// scalars (`curriculum_back`, `curriculum_scored`), `None` for one the env drew itself.
    pub fn on_episode(&mut self, info: &FoosballInfo) -> Option<Metrics> {
        info.replayed?;
        let back = self.back();
        self.window.push(info.episode_scored);
        if self.window.len() >= self.config.window as usize {
            let scored = self.window.iter().filter(|&&s| s).count();
            if scored as f64 >= self.config.success_rate * self.window.len() as f64 {
                let next = back.saturating_add(self.config.advance).min(self.longest);
                self.back.store(next, Ordering::Relaxed);
            }
            self.window.clear();
        }
        Some(Metrics(vec![
            ("curriculum_back", f64::from(back).into()),
            (
                "curriculum_scored",
                f64::from(u8::from(info.episode_scored)).into(),
            ),
        ]))
    }

    /// The state a checkpoint keeps.
    pub fn state(&self) -> CurriculumState {
        CurriculumState {
            back: self.back(),
            window: self.window.clone(),
        }
    }
}

/// Where a [`TeacherStarts`] takes its distance from the goal.
enum Distance {
    /// `schedule = "clock"`.
    Clock {
        /// This env's agent steps before the run (re)started (a resume's).
        steps_before: u64,
        /// This env's agent steps over the whole run.
        steps_in_run: f64,
    },
    /// `schedule = "success"`: the run's [`SuccessSchedule`].
    Success(Arc<AtomicU32>),
}

/// The starts of one training env: a teacher's episode with probability `share`, else the
/// env's own draw.
pub struct TeacherStarts {
    teacher: Arc<Vec<TeacherEpisode>>,
    config: CurriculumConfig,
    distance: Distance,
    rng: ChaCha8Rng,
}

impl EpisodeStarts for TeacherStarts {
    fn next_start(&mut self, env_steps: u64) -> Option<ReplayStart> {
        if self.rng.random::<f64>() >= self.config.share {
            return None;
        }
        let episode = &self.teacher[self.rng.random_range(0..self.teacher.len())];
        let back = match &self.distance {
            Distance::Clock {
                steps_before,
                steps_in_run,
            } => {
                let progress = (steps_before + env_steps) as f64 / steps_in_run;
                steps_back(&self.config, episode.goal_step(), progress)
            }
            Distance::Success(back) => {
                (back.load(Ordering::Relaxed) as usize).min(episode.goal_step())
            }
        };
        Some(ReplayStart {
            seed: episode.seed,
            actions: episode.actions[..episode.goal_step() - back].to_vec(),
        })
    }

    fn reseed(&mut self, seed: u64) {
        self.rng = ChaCha8Rng::seed_from_u64(derive_seed(seed, CURRICULUM, 0));
    }
}

/// The teacher's episodes of a run with a `[curriculum]`, read and checked
/// ([`teacher_episodes`]); `None` without one.
pub fn load_teacher(config: &RunConfig) -> Result<Option<Arc<Vec<TeacherEpisode>>>, String> {
    config
        .curriculum
        .as_ref()
        .map(|c| teacher_episodes(config, c).map(Arc::new))
        .transpose()
}

/// The run's `n` training envs on `config.env`, each beginning episodes along `teacher`'s
/// when given (the run's `[curriculum]`), as far back as `schedule` says under
/// `schedule = "success"`; `env_steps` is where the run (re)starts.
pub fn training_envs(
    config: &RunConfig,
    teacher: Option<&Arc<Vec<TeacherEpisode>>>,
    schedule: Option<&SuccessSchedule>,
    n: usize,
    env_steps: u64,
) -> Result<Vec<FoosballEnv>, String> {
    let envs = foosball_envs(&config.env, n).map_err(|e| e.to_string())?;
    let (Some(teacher), Some(c)) = (teacher, &config.curriculum) else {
        return Ok(envs);
    };
    let per_env = |steps: u64| steps as f64 / n as f64;
    Ok(envs
        .into_iter()
        .map(|env| {
            let distance = match schedule {
                Some(s) => Distance::Success(Arc::clone(&s.back)),
                None => Distance::Clock {
                    steps_before: per_env(env_steps) as u64,
                    steps_in_run: per_env(config.protocol.total_env_steps()),
                },
            };
            env.with_starts(Box::new(TeacherStarts {
                teacher: Arc::clone(teacher),
                config: c.clone(),
                distance,
                // Reseeded by the env's first reset, which has a seed.
                rng: ChaCha8Rng::seed_from_u64(0),
            }))
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curriculum(first_back: u32, whole_at: f64) -> CurriculumConfig {
        CurriculumConfig {
            first_back,
            whole_at,
            ..CurriculumConfig::default()
        }
    }

    #[test]
    fn episodes_begin_first_back_before_the_goal_then_further_back_until_the_start() {
        let c = curriculum(5, 0.5);
        assert_eq!(steps_back(&c, 40, 0.0), 5);
        assert_eq!(
            steps_back(&c, 40, 0.25),
            23,
            "halfway to whole_at: 5 + 35 / 2"
        );
        assert_eq!(steps_back(&c, 40, 0.5), 40, "the teacher's own start");
        assert_eq!(steps_back(&c, 40, 0.9), 40, "never before it");
        assert_eq!(
            steps_back(&c, 3, 0.0),
            3,
            "a goal nearer the start than first_back"
        );
    }

    #[test]
    fn the_share_and_the_schedule_decide_each_start() {
        let teacher = Arc::new(vec![TeacherEpisode {
            seed: 11,
            actions: vec![[0.5; ACTION_DIM]; 30],
        }]);
        let starts = |share: f64| TeacherStarts {
            teacher: Arc::clone(&teacher),
            config: CurriculumConfig {
                share,
                ..curriculum(4, 1.0)
            },
            distance: Distance::Clock {
                steps_before: 100,
                steps_in_run: 1000.0,
            },
            rng: ChaCha8Rng::seed_from_u64(3),
        };
        let mut never = starts(0.0);
        assert!((0..100).all(|_| never.next_start(0).is_none()));
        let mut always = starts(1.0);
        let first = always
            .next_start(0)
            .expect("share 1 always begins on the teacher");
        assert_eq!(first.seed, 11);
        // 10 % into the run: 4 + 26 * 0.1 = 6.6, 7 steps back of 30.
        assert_eq!(first.actions.len(), 23);
        // 100 + 400 of 1000 steps: 4 + 26 * 0.5 = 17 back.
        assert_eq!(always.next_start(400).unwrap().actions.len(), 13);
        let mut half = starts(0.5);
        let taken = (0..1000).filter(|_| half.next_start(0).is_some()).count();
        assert!((430..570).contains(&taken), "{taken} of 1000 at share 0.5");
    }

    /// A success schedule over a teacher whose longest episode is `longest` steps.
    fn success(window: u32, success_rate: f64, advance: u32, longest: u32) -> SuccessSchedule {
        SuccessSchedule {
            config: CurriculumConfig {
                schedule: CurriculumSchedule::Success,
                window,
                success_rate,
                advance,
                ..curriculum(3, 0.5)
            },
            back: Arc::new(AtomicU32::new(3)),
            window: Vec::new(),
            longest,
        }
    }

    fn ended(replayed: Option<u32>, scored: bool) -> FoosballInfo {
        FoosballInfo {
            replayed,
            episode_scored: scored,
            ..FoosballInfo::default()
        }
    }

    #[test]
    fn the_success_schedule_moves_back_after_a_window_that_scored_enough() {
        let mut s = success(4, 0.5, 2, 8);
        let shared = Arc::clone(&s.back);
        assert!(
            s.on_episode(&ended(None, true)).is_none(),
            "the env's own draws are not judged"
        );
        // 1 of 4: stays.
        for scored in [true, false, false, false] {
            assert!(s.on_episode(&ended(Some(10), scored)).is_some());
        }
        assert_eq!(s.back(), 3);
        // 2 of 4: back by 2, and every env sees it.
        for scored in [false, true, false, true] {
            s.on_episode(&ended(Some(0), scored));
        }
        assert_eq!(shared.load(Ordering::Relaxed), 5);
        for _ in 0..3 {
            s.on_episode(&ended(Some(2), true));
        }
        assert_eq!(s.back(), 5, "the window is not full yet");
        assert_eq!(
            s.state(),
            CurriculumState {
                back: 5,
                window: vec![true; 3]
            }
        );
        s.on_episode(&ended(Some(2), true));
        assert_eq!(s.back(), 7);
        for _ in 0..8 {
            s.on_episode(&ended(Some(0), true));
        }
        assert_eq!(s.back(), 8, "never beyond the teacher's longest episode");
        let m = s.on_episode(&ended(Some(1), false)).unwrap();
        assert_eq!(m.0[0].0, "curriculum_back");
        assert_eq!(m.0[1].0, "curriculum_scored");
    }

    #[test]
    fn a_success_start_is_as_far_back_as_the_schedule_says_within_its_episode() {
        let teacher = Arc::new(vec![TeacherEpisode {
            seed: 4,
            actions: vec![[0.1; ACTION_DIM]; 6],
        }]);
        let back = Arc::new(AtomicU32::new(2));
        let mut starts = TeacherStarts {
            teacher,
            config: CurriculumConfig {
                share: 1.0,
                ..curriculum(2, 0.5)
            },
            distance: Distance::Success(Arc::clone(&back)),
            rng: ChaCha8Rng::seed_from_u64(1),
        };
        assert_eq!(starts.next_start(0).unwrap().actions.len(), 4);
        back.store(5, Ordering::Relaxed);
        assert_eq!(starts.next_start(10_000).unwrap().actions.len(), 1);
        back.store(50, Ordering::Relaxed);
        assert_eq!(
            starts.next_start(0).unwrap().actions.len(),
            0,
            "the teacher's own start"
        );
    }

    #[test]
    fn a_success_schedules_state_survives_a_checkpoint() {
        let state = CurriculumState {
            back: 17,
            window: vec![true, false, true],
        };
        let mut snap = Snapshot::new();
        assert_eq!(CurriculumState::load(&snap).unwrap(), None);
        state.save(&mut snap);
        assert_eq!(CurriculumState::load(&snap).unwrap(), Some(state));
    }

    #[test]
    fn a_reseeded_chooser_chooses_again_as_it_did() {
        let teacher = Arc::new(
            (0..20)
                .map(|k| TeacherEpisode {
                    seed: k,
                    actions: vec![[0.0; ACTION_DIM]; 10],
                })
                .collect::<Vec<_>>(),
        );
        let mut starts = TeacherStarts {
            teacher,
            config: curriculum(2, 0.5),
            distance: Distance::Clock {
                steps_before: 0,
                steps_in_run: 100.0,
            },
            rng: ChaCha8Rng::seed_from_u64(0),
        };
        let draw = |s: &mut TeacherStarts| {
            s.reseed(77);
            (0..50)
                .map(|_| s.next_start(0).map(|r| r.seed))
                .collect::<Vec<_>>()
        };
        let first = draw(&mut starts);
        assert_eq!(draw(&mut starts), first);
        assert!(
            first
                .iter()
                .flatten()
                .collect::<std::collections::HashSet<_>>()
                .len()
                > 5
        );
    }
}
