//! The rounds of writing the re-timed program, simulating it as a program of
//! its own and correcting it ([`write_verified`]), after the engagement and
//! its caps ([`caps_and_rounds`]).

use std::path::Path;
use std::time::Instant;

use crate::error::{fail, Result, ResultExt as _};
use schedule::{CapKind, Machine, ServoSample, Stations};

use super::blocks::{
    apply_block_caps, refeed_plan, Blocks, MERGE_RATIO, MERGE_RATIO_MIN, PLAN_TOLERANCE,
};
use super::caps::{apply_interval_caps, cap_shares};
use super::engagement::{engagement_caps_on, SurfaceFrom};
use super::stations::FreeStations;
use super::verify::{excesses, lower_caps, within_limits, Excess, FeedRules, Given};
use crate::model::summary::CapShare;
use crate::motion::TimedStep;
use crate::run::Run;
use crate::setup::Setup;

/// What [`caps_and_rounds`] did: the engagement's stations and time, and the
/// rounds' result.
pub struct Rounds {
    /// Planner stations along the path.
    pub stations: usize,
    /// Wall time of the engagement sweep and the caps, s.
    pub time_engagement_s: f64,
    /// What the rounds wrote ([`write_verified`]).
    pub written: Written,
    /// When the rounds began (after the engagement).
    pub plan_started: Instant,
}

/// The engagement along the free `stations` (begun at `t1`), their caps
/// and the rounds of [`write_verified`]: the number of stations, the
/// engagement's time, what was written (optimized.nc into `staged`) and
/// when the rounds began.
pub fn caps_and_rounds(
    setup: &Setup,
    machine: &Machine,
    free: &mut FreeStations,
    given: Given,
    t1: Instant,
    staged: &Path,
) -> Result<Rounds> {
    let stations = free.stations(machine, setup)?;
    crate::util::heap_mark(format_args!("free stations"));
    let limits = &setup.job.limits;
    let surface = match (&setup.design, limits.angle_rule) {
        (_, false) => SurfaceFrom::Nothing,
        (Some((_, model)), true) => SurfaceFrom::Design(model),
        (None, true) => SurfaceFrom::Stock,
    };
    // The caps made as the sweep makes each interval's engagement final
    // (per station: loads, areas and angles not held).
    let (caps, rules) = engagement_caps_on(
        stations,
        &setup.stock_source(),
        &setup.tools,
        limits,
        surface,
    )?;
    let time_engagement_s = t1.elapsed().as_secs_f64();
    crate::util::heap_mark(format_args!("engagement and caps"));
    let t2 = Instant::now();
    let n_stations = stations.len();
    let written = write_verified(setup, machine, free, caps, &rules, given, staged)?;
    Ok(Rounds {
        stations: n_stations,
        time_engagement_s,
        written,
        plan_started: t2,
    })
}

/// Most rounds of writing, re-simulating and correcting the program.
pub const MAX_ROUNDS: usize = 12;

/// The program optimize writes, re-simulated as a program of its own.
pub struct Written {
    /// The written program simulated (the program as given where it is
    /// kept).
    pub run: Run,
    /// What its servo samples (servo.csv's rows) hold beside the run's steps
    /// ([`crate::motion::SampleFeeds::rows`]: 8 B a sample held beside the
    /// run instead of 72).
    pub samples: crate::motion::SampleFeeds,
    /// Cycle time of the plan as written (each block at its feed, the
    /// machine's acceleration), s.
    pub plan_time_s: f64,
    /// Cycle time of the time-optimal timing under the final caps (feeds free
    /// to change at every station), s.
    pub time_optimal_s: f64,
    /// Σ Δs / cap under the final caps, s.
    pub lower_bound_time_s: f64,
    pub cap_shares: Vec<CapShare>,
    /// Rounds of write → re-simulate → correct.
    pub rounds: usize,
    /// Feeds within this ratio share a block in the written program.
    pub merge_ratio: f64,
    /// Servo periods still above a limit by more than its tolerance after the
    /// last round, where the tool advanced at least a grid cell.
    pub excesses_left: usize,
    /// The original program was within every limit and faster: it is written unchanged.
    pub kept_original: bool,
    /// Periods above a limit by more than its tolerance after the last round,
    /// where the tool advanced less than a grid cell (see [`Excess::resolved`]).
    pub unresolved: Vec<Excess>,
}

/// Write the re-timed program, simulate it as a program of its own (parsed
/// again and planned by the machine model), and correct it until every servo
/// period is within the limits and its cycle time is within
/// [`PLAN_TOLERANCE`] of the plan: periods over a limit lower the caps there,
/// a written program slower than the plan gets finer blocks (down to
/// [`MERGE_RATIO_MIN`]; what remains comes from lines `nc::refeed` cannot
/// split per run, which take one feed: MODEL.md §2.2). When the
/// original program is within every limit and the result would be slower,
/// the original is kept: within every limit as the written program is
/// judged ([`excesses`]), with `rules`, the feed rules of the engagement
/// that made `caps` ([`FeedRules`]: S3's angle rule), so it is simulated
/// again and judged by them before it is kept. The program's path is read from `free`'s
/// ([`FreeStations::path`]): the setup's may be lent to them. `free`'s
/// arrays are let go while the written program is verified and made again
/// (by `machine`) for a next round. A G-code program's text is written to
/// `out_dir`'s optimized.nc as each round makes it (the original's where it
/// is kept), not held through the verification: `out_dir` is a staging
/// folder, committed whole when every file is written.
pub fn write_verified(
    setup: &Setup,
    machine: &Machine,
    free: &mut FreeStations,
    mut caps: Vec<(f64, CapKind)>,
    rules: &FeedRules,
    before: Given,
    out_dir: &Path,
) -> Result<Written> {
    let limits = &setup.job.limits;
    let margin_mm = 2.0 * setup.stock.grid().spacing_mm;
    let mut merge_ratio = MERGE_RATIO;
    let mut round = 0;
    loop {
        round += 1;
        let stations = free.stations(machine, setup)?;
        let RoundPlan {
            plan,
            optimum_samples,
            blocks,
            times,
        } = plan_round(setup, machine, stations, &caps, merge_ratio)?;
        // Nor are the caps read again before the verification's excesses
        // lower them for a next round: held as two columns meanwhile (9 B an
        // interval, not 16: 27 MB for 3 M free stations, not 48), made again
        // as they were where a next round needs them.
        let (cap_feeds, cap_kinds): (Vec<f64>, Vec<CapKind>) =
            std::mem::take(&mut caps).into_iter().unzip();
        crate::util::heap_mark(format_args!("round {round}: plans"));
        // Nor are the stations' arrays needed while the program is written,
        // read back and verified (3 M stations: 143 MB beside the re-feed's
        // readings and the run): only their path is kept, and a next round
        // makes them again (the same stations, their caps as made).
        free.release();
        let (sample_feeds, steps) =
            written_steps(setup, free, plan, optimum_samples, out_dir, round)?;
        crate::util::heap_mark(format_args!("round {round}: servo samples and steps"));
        let run = crate::run::run_on(
            setup.stock_source(),
            &setup.tools,
            steps,
            &format!("verify {round}"),
        )?;
        crate::util::heap_mark(format_args!("round {round}: verification run"));
        let over = excesses(&run, limits, &setup.tools, rules);
        crate::util::heap_mark(format_args!("round {round}: excesses"));
        let gcode = setup.program.gcode.as_deref();
        let slow = gcode.is_some()
            && run.steps.last().map_or(0.0, |s| s.t_end_s)
                > times.plan_time_s * (1.0 + PLAN_TOLERANCE);
        let refine_blocks = slow && merge_ratio > MERGE_RATIO_MIN;
        // Every period over a limit lowers its caps; the rounds end when none
        // is over by more than its tolerance.
        // (An excess without a finite cap has nothing to lower.)
        let done = (!over
            .iter()
            .any(|e| e.beyond_tolerance && e.cap_mm_min.is_finite())
            && !refine_blocks)
            || round >= MAX_ROUNDS;
        if done {
            let verified = Verified {
                run,
                samples: sample_feeds,
                over,
            };
            let last = LastRound {
                round,
                merge_ratio,
                times,
            };
            return finish(setup, free, out_dir, before, rules, verified, last);
        }
        // The run is let go before the stations are made again (their
        // path read again from the program's text).
        drop(run);
        caps = cap_feeds.into_iter().zip(cap_kinds).collect();
        lower_caps(
            &mut caps,
            free.stations(machine, setup)?.s_mm(),
            &blocks,
            &over,
            margin_mm,
            limits.feed_min,
        );
        if refine_blocks {
            merge_ratio = (1.0 + (merge_ratio - 1.0) / 2.5).max(MERGE_RATIO_MIN);
        }
    }
}

/// Writes a G-code program's text to `out_dir`'s optimized.nc, atomically.
fn write_text(out_dir: &Path, text: &str) -> Result<()> {
    let file = out_dir.join("optimized.nc");
    export::atomic::write_bytes(&file, text.as_bytes())
        .map_err(|e| crate::error::Error::io("cannot write", &file, e))
}

/// What a round keeps of its plans through the verification: their times
/// and the cap shares of the plan as written.
struct PlanTimes {
    /// Cycle time of the plan as written, s.
    plan_time_s: f64,
    /// Cycle time of the time-optimal timing under the caps, s.
    time_optimal_s: f64,
    /// Σ Δs / cap under the caps, s.
    lower_bound_time_s: f64,
    /// Share of the plan as written's time at each kind of cap.
    cap_shares: Vec<CapShare>,
}

/// One round's plans on the free stations ([`plan_round`]).
struct RoundPlan {
    /// The re-feed plan ([`refeed_plan`]): read by the re-feed alone.
    plan: Vec<Vec<(f64, f64)>>,
    /// A point list's servo samples of the optimum (None for G-code).
    optimum_samples: Option<Vec<ServoSample>>,
    /// Where the refeed plan's blocks begin among the intervals.
    blocks: Blocks,
    /// What the round keeps of the plans.
    times: PlanTimes,
}

/// The plans of a round under `caps`, made one after the other on the
/// stations themselves.
fn plan_round(
    setup: &Setup,
    machine: &Machine,
    stations: &mut Stations,
    caps: &[(f64, CapKind)],
    merge_ratio: f64,
) -> Result<RoundPlan> {
    // The two plans are made one after the other on the stations
    // themselves, their caps put back after each (no copy of the
    // stations), and dropped before the written program is simulated:
    // what the rounds keep of them is their times, the refeed plan, the
    // cap shares and, for a point list, the servo samples.
    let (plan, time_optimal_s, lower_bound_time_s) = stations.with_caps_restored(|stations| {
        apply_interval_caps(stations, caps)?;
        // Only its time is kept: the profile (32 B a station) is let
        // go before the bound and the refeed plan are made.
        let time_optimal_s = schedule::plan(stations).cycle_time_s();
        let lower_bound_time_s = schedule::lower_bound_time_s(stations);
        let plan = refeed_plan(stations, caps, machine, merge_ratio);
        Ok::<_, crate::error::Error>((plan, time_optimal_s, lower_bound_time_s))
    })?;
    // The plan as written: every interval at its block's feed.
    let as_written = |blocks: &mut Stations| {
        apply_block_caps(blocks, &plan, caps)?;
        let profile = schedule::plan(blocks);
        Ok::<_, crate::error::Error>((profile.cycle_time_s(), cap_shares(&profile)))
    };
    // A G-code program's stations are let go after it (below) without
    // their caps put back (no copy of them, 9 B a station); a
    // point list's optimum is planned on them again.
    let (plan_time_s, shares) = match setup.program.gcode {
        Some(_) => as_written(stations)?,
        None => stations.with_caps_restored(as_written)?,
    };
    // Caps from tiny limits (mrr_max 1e-4) would make the written program run for days.
    crate::bounds::check_samples(
        plan_time_s.max(time_optimal_s),
        machine.period_ms,
        "the re-timed program ([limits] caps: mrr_max, force_max, deflection_max_um, the tool's stress_limit_mpa)",
    )?;
    // A point list is written as the optimum's servo samples: that plan again.
    let optimum_samples = match &setup.program.gcode {
        Some(_) => None,
        None => Some(stations.with_caps_restored(|stations| {
            apply_interval_caps(stations, caps)?;
            Ok::<_, crate::error::Error>(schedule::plan(stations).sample(machine.period_ms)?)
        })?),
    };
    // What a next round needs of the refeed plan is where its blocks
    // begin among the intervals: kept instead of the plan (a million segments' pieces, one
    // `Vec` each, 40 MB), which is dropped before the sweep.
    let blocks = Blocks::of(stations, &plan);
    Ok(RoundPlan {
        plan,
        optimum_samples,
        blocks,
        times: PlanTimes {
            plan_time_s,
            time_optimal_s,
            lower_bound_time_s,
            cap_shares: shares,
        },
    })
}

/// The written program's steps and what servo.csv needs of its samples
/// beside them (their feeds). A G-code program is written (to `out_dir`'s
/// optimized.nc) by the re-feed of `plan` and read back; a point list is
/// `optimum_samples`. The written program's path is lent to its planner,
/// and dropped once its steps and the samples' feeds are made, with the
/// samples (before the sweep).
fn written_steps(
    setup: &Setup,
    free: &mut FreeStations,
    plan: Vec<Vec<(f64, f64)>>,
    optimum_samples: Option<Vec<ServoSample>>,
    out_dir: &Path,
    round: usize,
) -> Result<(crate::motion::SampleFeeds, Vec<TimedStep>)> {
    Ok(match &setup.program.gcode {
        Some(src) => {
            // The written program as the re-feed writer read it back to
            // check it (with the program's options, as `nc::parse` reads
            // it): not read once more.
            // The program's path handed to the re-feed (the stations are
            // let go): the source's reading makes it again, and holds
            // it, not a second copy, where it makes it bit for bit (126
            // MB for a million blocks); it is let go before the written
            // text is read back, and read again from the program's text
            // where a next round or the caller needs it (0.7 s CPU for a
            // million blocks). The path is in dexcut's frame, the text
            // reads in its own: mirrored for a Z that points down.
            let (file, options) = (&setup.program.file, &setup.program.nc_options);
            let mut path = free.give(setup)?;
            if setup.program.z_down {
                path.mirror_z();
            }
            let read = nc::refeed_read_along(src, file, options, &plan, path);
            // Read by the re-feed alone (40 MB of pieces for a million
            // segments, not held while the samples and steps are made).
            drop(plan);
            let (text, parsed) =
                read.or_run(|| format!("{file}: cannot write the re-fed program"))?;
            // Written now and let go (60 MB for a million blocks).
            write_text(out_dir, &text)?;
            drop(text);
            let parsed = setup.program.in_frame(parsed);
            if let Some(d) = parsed.diagnostics.iter().find(|d| d.is_error()) {
                fail!(run, "the re-fed program does not read back: {d}");
            }
            let path = parsed.path;
            crate::util::heap_mark(format_args!("round {round}: re-feed"));
            let (samples, path) =
                crate::motion::machine_motion_of(path, &setup.machine, &setup.controller);
            let samples = samples?;
            let steps = crate::motion::steps_from_samples(&path, &samples);
            let feeds = crate::motion::SampleFeeds::of(&samples, &path);
            (feeds, steps)
        }
        None => {
            drop(plan);
            let samples = optimum_samples.expect("sampled for a point list");
            free.with_path(setup, |path| {
                let steps = crate::motion::steps_from_samples(path, &samples);
                (crate::motion::SampleFeeds::of(&samples, path), steps)
            })?
        }
    })
}

/// A round's written program simulated: its run, what servo.csv needs of
/// its samples, and its periods over a limit.
struct Verified {
    run: Run,
    samples: crate::motion::SampleFeeds,
    over: Vec<Excess>,
}

/// Which round was the last, at which merge ratio, and its plans' times.
struct LastRound {
    round: usize,
    merge_ratio: f64,
    times: PlanTimes,
}

/// The rounds' result: the last round's written program, or the program as
/// given where it is within every limit and faster (written to `out_dir`'s
/// optimized.nc and simulated again). The program as given is judged by
/// `rules` on that run, with the check the written program had
/// ([`within_limits`]); where it breaks one, the written program stays.
fn finish(
    setup: &Setup,
    free: &mut FreeStations,
    out_dir: &Path,
    before: Given,
    rules: &FeedRules,
    verified: Verified,
    last: LastRound,
) -> Result<Written> {
    let Verified {
        run,
        samples: sample_feeds,
        over,
    } = verified;
    let LastRound {
        round,
        merge_ratio,
        times,
    } = last;
    let gcode = setup.program.gcode.as_deref();
    let cycle = run.steps.last().map_or(0.0, |s| s.t_end_s);
    let faster_within = cycle > before.cycle_s && before.within_limits_but_feed_rules;
    let (left, unresolved): (Vec<Excess>, Vec<Excess>) = over
        .into_iter()
        .filter(|e| e.beyond_tolerance)
        .partition(|e| e.resolved);
    let (run, sample_feeds, kept_original) = match (faster_within, gcode) {
        (true, Some(original)) => {
            // The written program is let go first, unless rules remain
            // to judge the program as given by: then it stays the result
            // where the program as given breaks one (both runs held).
            let written = if rules.is_empty() {
                drop((run, sample_feeds));
                None
            } else {
                Some((run, sample_feeds))
            };
            // The program as given, simulated again (its run was not
            // held through the rounds).
            let (steps, feeds) = free.with_path(setup, |path| {
                let samples =
                    crate::motion::machine_motion(path, &setup.machine, &setup.controller)?;
                Ok::<_, crate::error::Error>((
                    crate::motion::steps_from_samples(path, &samples),
                    crate::motion::SampleFeeds::of(&samples, path),
                ))
            })??;
            let given = crate::run::run_on(setup.stock_source(), &setup.tools, steps, "as given")?;
            match written {
                Some(written) if !within_limits(&given, &setup.job.limits, &setup.tools, rules) => {
                    drop((given, feeds));
                    (written.0, written.1, false)
                }
                written => {
                    drop(written);
                    write_text(out_dir, original)?;
                    (given, feeds, true)
                }
            }
        }
        _ => (run, sample_feeds, false),
    };
    Ok(Written {
        run,
        samples: sample_feeds,
        plan_time_s: times.plan_time_s,
        time_optimal_s: times.time_optimal_s,
        lower_bound_time_s: times.lower_bound_time_s,
        cap_shares: times.cap_shares,
        rounds: round,
        merge_ratio,
        excesses_left: left.len(),
        unresolved,
        kept_original,
    })
}
