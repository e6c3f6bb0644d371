//! Tests of the optimisation's pieces: engagement, windowed areas, caps, blocks.

use super::engagement::{surface_angles_deg, SweepMoves};
use super::*;
use cutting::CuttingModel;
use dexel::SweepOptions;
use nc::Motion;
use schedule::{CapKind, Stations};

use crate::input::job::LimitsSpec;
use crate::input::tools::ToolSet;
use crate::motion::STATION_DS_MM;
use crate::run::StockSource;
use crate::setup::Setup;

/// [`windowed_area`] over whole lists as it was before the areas were
/// made as the volumes come (the oracle of the tests below).
fn windowed_area_of_lists(s_mm: &[f64], volumes_mm3: &[f64], window_mm: f64) -> Vec<f64> {
    let n = volumes_mm3.len();
    let mut cum = Vec::with_capacity(n + 1);
    cum.push(0.0);
    for v in volumes_mm3 {
        cum.push(cum[cum.len() - 1] + v);
    }
    let half = 0.5 * window_mm;
    let (s_first, s_last) = (s_mm[0], s_mm[n]);
    let cum_at = |x: f64, i: &mut usize| {
        let x = x.clamp(s_first, s_last);
        while *i + 1 < n && s_mm[*i + 1] < x {
            *i += 1;
        }
        let (a, b) = (s_mm[*i], s_mm[*i + 1]);
        let f = if b > a {
            ((x - a) / (b - a)).clamp(0.0, 1.0)
        } else {
            1.0
        };
        cum[*i] + f * volumes_mm3[*i]
    };
    let (mut lo, mut hi) = (0usize, 0usize);
    let mean: Vec<f64> = (0..n)
        .map(|k| {
            let mid = 0.5 * (s_mm[k] + s_mm[k + 1]);
            let (a, b) = ((mid - half).max(s_first), (mid + half).min(s_last));
            if b > a {
                (cum_at(b, &mut hi) - cum_at(a, &mut lo)) / (b - a)
            } else {
                0.0
            }
        })
        .collect();
    let mut out = vec![0.0; n];
    let mut deque: std::collections::VecDeque<usize> = std::collections::VecDeque::new();
    let mut next = 0;
    for k in 0..n {
        let mid = 0.5 * (s_mm[k] + s_mm[k + 1]);
        while next < n && 0.5 * (s_mm[next] + s_mm[next + 1]) <= mid + half {
            while deque.back().is_some_and(|&b| mean[b] <= mean[next]) {
                deque.pop_back();
            }
            deque.push_back(next);
            next += 1;
        }
        while deque
            .front()
            .is_some_and(|&f| 0.5 * (s_mm[f] + s_mm[f + 1]) < mid - half)
        {
            deque.pop_front();
        }
        out[k] = deque.front().map_or(mean[k], |&f| mean[f]);
    }
    out
}

/// The reference loads from the record held whole, as they were made
/// before the sweep gave its rows to them (the oracle).
fn reference_loads_of_record<'a>(
    record: &dexel::RemovalRecord,
    moves: &SweepMoves,
    area_mm2: &[f64],
    s_mm: &[f64],
    model_of: impl Fn(usize) -> &'a CuttingModel,
    (steps, cell_mm): (&[dexel::Step], f64),
) -> Vec<ReferenceLoad> {
    let n = area_mm2.len();
    let first_cut = (0..moves.len()).find(|&j| record.volume_mm3(j) > 0.0);
    let mut last = None;
    let mut bands = vec![0.0; record.n_bands];
    let move_of: Vec<usize> = (0..moves.len())
        .flat_map(|j| moves.intervals(j).map(move |_| j))
        .collect();
    (0..n)
        .map(|k| {
            let m = move_of[k];
            if record.volume_mm3(m) > 0.0 {
                last = Some(m);
            }
            let (Some(j), true) = (last.or(first_cut), area_mm2[k] > 0.0) else {
                return cutting::StepLoad::default().into();
            };
            let run = moves.intervals(j);
            let len_mm = s_mm[k + 1] - s_mm[k];
            let volume = area_mm2[k] * len_mm;
            let scale = volume / record.volume_mm3(j);
            bands.fill(0.0);
            for (b, v) in bands.iter_mut().zip(record.band_volumes_mm3(j)) {
                *b = v * scale;
            }
            let [cx, cy] = record.contact_resultant(j);
            let load = model_of(k).step_load(&cutting::StepRemoval {
                volume_mm3: volume,
                band_volumes_mm3: &bands,
                contact_resultant: [cx * scale, cy * scale],
                chip_edge_area_mm2: record.chip_edge_area_mm2(j)
                    * scale
                    * (s_mm[run.end] - s_mm[run.start])
                    / len_mm,
                volume_over_radius_mm2: record.volume_over_radius_mm2(j) * scale,
                dt_s: len_mm * 60.0 / REFERENCE_FEED_MM_MIN,
                band_offsets_mm: record.band_offsets_mm(j),
                feed_dir: crate::run::feed_dir(&steps[run.start]),
                len_xy_mm: crate::run::len_xy_mm(&steps[k]),
                cell_mm,
            });
            ReferenceLoad::from(load)
        })
        .collect()
}

/// The caps as [`interval_caps`] made them in one piece (the oracle).
fn caps_in_one_piece(
    engagement: &Engagement,
    stations: &Stations,
    limits: &LimitsSpec,
    tools: &ToolSet,
) -> Vec<(f64, CapKind)> {
    let (segs, seg_of) = (stations.segments(), stations.segment());
    (0..engagement.area_mm2.len())
        .map(|k| {
            let a = engagement.area_mm2[k];
            let entry = &tools.entries[usize::from(engagement.tool_index[k])];
            let model = &entry.model;
            let mut cap = (f64::INFINITY, CapKind::FeedMax);
            let mut lower = |v: f64, kind: CapKind| {
                if v < cap.0 {
                    cap = (v, kind);
                }
            };
            if a > 1e-12 {
                let seg = &segs[seg_of[k + 1] as usize];
                if let Some(f) = entry.chip_load_feed_mm_min(seg.spindle_rpm) {
                    lower(f, CapKind::ChipLoad);
                }
                if let (Some(scale), Motion::Feed { feed_mm_min, .. }) =
                    (limits.feed_scale_max, seg.motion)
                {
                    lower(scale * feed_mm_min, CapKind::FeedScale);
                }
                if let Some(q) = limits.mrr_max {
                    lower(60.0 * q / a, CapKind::Removal);
                }
                let at_ref = &engagement.reference_loads[k];
                let cap = |q_ref: f64, limit: f64| {
                    model.feed_for_limit(q_ref, REFERENCE_FEED_MM_MIN, limit)
                };
                if let Some(f) = limits.force_max {
                    lower(cap(at_ref.force_peak_n, f), CapKind::Force);
                }
                if let Some(d_um) = limits.deflection_max_um {
                    lower(cap(at_ref.deflection_um, d_um), CapKind::Deflection);
                }
                if let Some(p_kw) = limits.power_max_kw {
                    lower(cap(at_ref.power_w, 1000.0 * p_kw), CapKind::Power);
                }
                if limits.stress {
                    lower(
                        cap(at_ref.stress_mpa, entry.stress_limit_mpa),
                        CapKind::Stress,
                    );
                }
                let theta_deg = engagement.surface_angle_deg[k];
                if let (true, Some(v0), false, Motion::Feed { feed_mm_min, .. }) =
                    (limits.angle_rule, limits.v0, theta_deg.is_nan(), seg.motion)
                {
                    lower(
                        schedule::angle_rule_feed_mm_min(theta_deg, feed_mm_min, v0),
                        CapKind::SurfaceAngle,
                    );
                }
            }
            if let Some(lo) = limits.feed_min {
                cap.0 = cap.0.max(lo);
            }
            cap
        })
        .collect()
}

/// Each interval's block from where the blocks begin is the run of equal
/// block indices around it in the list of every interval's (walked as
/// [`lower_caps`] walked that list): blocks of one interval and of many,
/// at both ends, a block index that comes back after another.
/// The first and last index of the run of equal entries of `list` that
/// holds index `k`: the oracle of [`Blocks::around`].
fn run_around<T: PartialEq>(list: &[T], k: usize) -> (usize, usize) {
    let (mut from, mut to) = (k, k);
    while from > 0 && list[from - 1] == list[from] {
        from -= 1;
    }
    while to + 1 < list.len() && list[to + 1] == list[to] {
        to += 1;
    }
    (from, to)
}

#[test]
fn blocks_from_where_they_begin_are_the_runs_of_the_list() {
    let lists: [&[u32]; 5] = [
        &[0],
        &[3, 3, 3],
        &[0, 1, 1, 2, 2, 2, 3, 4, 4],
        &[0, 0, 1, 0, 0, 7, 7],
        &[5, 6, 7, 8],
    ];
    for list in lists {
        let blocks = Blocks::where_they_change(list.iter());
        assert_eq!(blocks.intervals, list.len());
        for k in 0..list.len() {
            assert_eq!(blocks.around(k), run_around(list, k), "{list:?} at {k}");
        }
    }
}

/// Per interval, the block of the written program it lies in, as
/// `interval_blocks` made it before the blocks were held as where they
/// begin (the oracle of the test below).
fn interval_blocks_listed(stations: &Stations, plan: &[Vec<(f64, f64)>]) -> Vec<u32> {
    let (seg_of, frac) = (stations.segment(), stations.fraction());
    let mut first_piece = Vec::with_capacity(plan.len());
    let mut n = 0;
    for pieces in plan {
        first_piece.push(n);
        n += pieces.len().max(1);
    }
    (0..stations.len() - 1)
        .map(|k| {
            let seg = seg_of[k + 1] as usize;
            let f = frac[k + 1];
            let piece = plan[seg].iter().position(|p| p.0 >= f - 1e-9).unwrap_or(0);
            u32::try_from(first_piece[seg] + piece).unwrap()
        })
        .collect()
}

/// The blocks of a program's free stations under its refeed plans (at
/// the merge ratios the rounds use, and 1: one block per cap change)
/// are, around every interval, the runs of equal block indices of the
/// list every interval's block was held in before (which
/// [`lower_caps`] widens a sub-cell removal excess to).
#[test]
fn blocks_of_a_refeed_plan_are_those_of_the_list() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("job.toml"),
        "[stock]\nkind = \"box\"\nmin = [0, 0, 0]\nmax = [60, 40, 20]\ngrid = 0.2\n\
         [tool]\nkind = \"ball\"\ndiameter = 6\n\
         [program]\npath = \"p.ngc\"\n[cutting]\nmaterial = \"al6061\"\n\
         [machine]\nfeed_max = 3000\naccel = [1000, 1000, 1000]\n\
         [limits]\nmrr_max = 40\nforce_max = 150\nfeed_min = 30\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("p.ngc"),
        "G21 G90 G17\nS9000 M3\nG0 X-8 Y5 Z25\nG1 X5 Z19 F1200\nG1 X30 Y20 Z18.5\n\
         G2 X40 Y30 I10 J0 F900\nG0 Z25\nG0 X10 Y30\nG1 Z17 F300\nG1 X50 Y32 F1500\n\
         G1 X52 F1500\nG1 X12 Y10 Z18.8 F1000\nG0 Z25\nM2\n",
    )
    .unwrap();
    let setup = Setup::load(&dir.path().join("job.toml"), None).unwrap();
    let limits = &setup.job.limits;
    let machine = optimising_machine(&setup.machine, limits);
    let stations = free_stations(&setup.program.path, &machine).unwrap();
    let caps = engagement_caps_on(
        &stations,
        &setup.stock_source(),
        &setup.tools,
        limits,
        SurfaceFrom::Nothing,
    )
    .unwrap()
    .0;
    for merge_ratio in [1.0, MERGE_RATIO_MIN, MERGE_RATIO] {
        let plan = refeed_plan(&stations, &caps, &machine, merge_ratio);
        let list = interval_blocks_listed(&stations, &plan);
        let blocks = Blocks::of(&stations, &plan);
        assert_eq!(blocks.intervals, list.len());
        // Blocks of one interval and of many: the plan splits segments.
        assert!(blocks.starts.len() > plan.iter().filter(|p| !p.is_empty()).count());
        for k in 0..list.len() {
            assert_eq!(
                blocks.around(k),
                run_around(&list, k),
                "ratio {merge_ratio} at {k}"
            );
        }
    }
}

/// Areas made as the volumes come equal those of whole lists, bit for
/// bit: stations of uneven spacing with repeated ones (zero-length
/// intervals), windows from under one interval to many, volumes of
/// every size, zero and NaN.
#[test]
fn windowed_areas_as_the_volumes_come_are_those_of_whole_lists() {
    let mut s = vec![0.0];
    for i in 0..400u32 {
        let ds = match i % 7 {
            0 => 0.0,
            3 => 0.013,
            5 => 0.21,
            _ => 0.05,
        };
        s.push(s[s.len() - 1] + ds);
    }
    let v: Vec<f64> = (0..400u32)
        .map(|i| match i % 11 {
            0..=2 => 0.0,
            4 if i == 202 => f64::NAN,
            _ => f64::from(i * 37 % 19) * 0.3 + 1e-3 * f64::from(i),
        })
        .collect();
    for window in [0.01, 0.1, 0.2, 0.37, 2.0, 50.0] {
        for n in [0, 1, 2, 5, 400] {
            let (s, v) = (&s[..=n], &v[..n]);
            let bits = |a: Vec<f64>| a.into_iter().map(f64::to_bits).collect::<Vec<_>>();
            assert_eq!(
                bits(windowed_area(s, v, window)),
                bits(windowed_area_of_lists(s, v, window)),
                "window {window}, {n} intervals"
            );
        }
    }
}

/// The engagement and caps made as the sweep gives its rows (no record
/// held) equal those made from the record held whole (the computation
/// before, kept above), bit for bit: three tools of 24, 16 and 12 bands,
/// rapids, plunges, an arc, air before the first cut (intervals there
/// take the first cut's shape), every limit and S3's angles from the
/// swept stock; and on the same stock held in bands (its rows given
/// once the record is finished). Two blocks 0.1 µm off one line (the last
/// digit a program in mm writes): the sweep's moves cross their junction.
#[test]
fn engagement_from_the_sweeps_rows_is_the_records() {
    let dir = tempfile::tempdir().unwrap();
    let tool = |n: u32, kind: &str, d: f64| {
        format!("[[tools]]\nnumber = {n}\nkind = \"{kind}\"\ndiameter = {d}\n")
    };
    let job = format!(
        "[stock]\nkind = \"box\"\nmin = [0, 0, 0]\nmax = [60, 40, 20]\ngrid = 0.2\n\
         {}{}corner_radius = 1\n{}\
         [program]\npath = \"p.ngc\"\n[cutting]\nmaterial = \"al6061\"\nband_height = 0.5\n\
         [machine]\nfeed_max = 3000\naccel = [1000, 1000, 1000]\n\
         [limits]\nmrr_max = 40\nforce_max = 150\ndeflection_max_um = 20\npower_max_kw = 0.4\n\
         feed_min = 30\nfeed_scale_max = 1.5\nangle_rule = true\nv0 = 300\n",
        tool(1, "ball", 6.0),
        tool(2, "bull", 4.0),
        tool(3, "flat", 3.0),
    );
    std::fs::write(dir.path().join("job.toml"), job).unwrap();
    std::fs::write(
        dir.path().join("p.ngc"),
        "G21 G90 G17\nT1 M6 S9000 M3\nG0 X-8 Y5 Z25\nG1 X5 Z19 F1200\nG1 X30 Y20 Z18.5\n\
         G2 X40 Y30 I10 J0 F900\nG0 Z25\nG0 X10 Y30\nG1 Z17 F300\nG1 X30 Y31.0001 F1500\nG1 X50 Y32\n\
         T2 M6 S12000 M3\nG0 Z25\nG0 X50 Y8\nG1 Z18 F200\nG1 X12 Y10 Z18.8 F1000\nG0 Z25\n\
         T3 M6 S15000 M3\nG0 X20 Y15\nG1 Z19 F250\nG1 X35 F800\nG1 Y35 Z18.5\nG0 Z25\nM2\n",
    )
    .unwrap();
    for budget_mb in [None, Some(1.0)] {
        let setup =
            Setup::load_within(&dir.path().join("job.toml"), None, None, budget_mb).unwrap();
        assert_eq!(setup.tiling.is_some(), budget_mb.is_some());
        let limits = &setup.job.limits;
        let machine = optimising_machine(&setup.machine, limits);
        let stations = free_stations(&setup.program.path, &machine).unwrap();
        // The reference loads made in more than one batch.
        assert!(
            stations.len() > 2 * super::engagement::LOAD_BATCH,
            "{}",
            stations.len()
        );
        let stock = setup.stock_source();
        // A tiled stock takes no angles from its surface.
        let surface = match stock {
            StockSource::Tiled(_) => SurfaceFrom::Nothing,
            _ => SurfaceFrom::Stock,
        };
        let tools = &setup.tools;
        let engagement = engagement_on(&stations, &stock, tools, surface).unwrap();
        // The record held whole, and what was made of it.
        let options = SweepOptions {
            band_height_mm: tools.entries[0].model.band_height_mm,
            ..SweepOptions::default()
        };
        let (segs, seg_of) = (stations.segments(), stations.segment());
        let steps: Vec<dexel::Step> = (1..stations.len())
            .map(|k| dexel::Step {
                from_mm: stations.position_at(k - 1).coords.into(),
                to_mm: stations.position_at(k).coords.into(),
                rapid: matches!(segs[seg_of[k] as usize].motion, Motion::Rapid),
            })
            .collect();
        // The sweep's moves: runs of up to 8 intervals (0.4 mm, the window) along the lines.
        let moves = SweepMoves::new(&stations, stock.grid().spacing_mm);
        assert!(moves.len() < steps.len() / 2, "{} moves", moves.len());
        // Each move's intervals (interval k on seg_of[k + 1]) lie on one
        // segment, or where there are several on lines of one tool and kind
        // of motion whose stations keep within JOIN_TOL_MM of the move's
        // chord, at most the window long; together in order.
        let window_mm = ENGAGEMENT_WINDOW_CELLS * stock.grid().spacing_mm;
        let mut next = 0;
        let mut crossing = 0;
        for j in 0..moves.len() {
            let run = moves.intervals(j);
            assert_eq!(run.start, next, "move {j}");
            next = run.end;
            let seg = |k: usize| &segs[seg_of[k + 1] as usize];
            if run.len() > 1 {
                let first = seg(run.start);
                assert!(run.clone().all(|k| {
                    let s = seg(k);
                    matches!(s.geometry, nc::Geometry::Line)
                        && s.tool == first.tool
                        && matches!(s.motion, Motion::Rapid)
                            == matches!(first.motion, Motion::Rapid)
                }));
                let s = stations.s_mm();
                assert!(
                    s[run.end] - s[run.start] <= window_mm * (1.0 + 1e-9),
                    "move {j}"
                );
                let (a, b) = (
                    stations.position_at(run.start),
                    stations.position_at(run.end),
                );
                for k in run.start + 1..run.end {
                    let at = |p: nalgebra::Point3<f64>| -> [f64; 3] { p.coords.into() };
                    let off = servo::path_error::dist2_point_segment(
                        at(stations.position_at(k)),
                        at(a),
                        at(b),
                    )
                    .sqrt();
                    assert!(off <= super::engagement::JOIN_TOL_MM, "move {j}: {off} mm");
                }
                crossing += usize::from(seg_of[run.start + 1] != seg_of[run.end]);
            }
        }
        assert_eq!(next, steps.len());
        assert!(
            crossing > 0,
            "no move crosses the junction of the line in two blocks"
        );
        assert!(
            (0..moves.len()).any(|j| moves.intervals(j).len() == 1
                && matches!(
                    segs[seg_of[moves.intervals(j).end] as usize].geometry,
                    nc::Geometry::Arc { .. }
                )),
            "the arc's intervals are moves of their own"
        );
        let move_steps: Vec<dexel::Step> =
            (0..moves.len()).map(|j| moves.step(&stations, j)).collect();
        let move_tools = moves.tools(&engagement.tool_index);
        let (swept, record) = crate::run::sweep_pass(
            &stock.initial(),
            None,
            tools,
            &move_tools,
            &move_steps,
            &options,
            "engagement",
        )
        .unwrap();
        let volumes: Vec<f64> = (0..moves.len())
            .flat_map(|j| {
                let (moves, s) = (&moves, stations.s_mm());
                let v = record.volume_mm3(j);
                moves
                    .intervals(j)
                    .map(move |k| moves.interval_volume_mm3(s, j, k, v))
            })
            .collect();
        // The split keeps each move's volume.
        for j in 0..moves.len() {
            let split: f64 = moves.intervals(j).map(|k| volumes[k]).sum();
            let v = record.volume_mm3(j);
            assert!(
                (split - v).abs() <= 1e-12 * v.max(1.0),
                "move {j}: {split} against {v}"
            );
        }
        assert_eq!(volumes.len(), steps.len());
        let window_mm =
            (ENGAGEMENT_WINDOW_CELLS * stock.grid().spacing_mm).max(2.0 * STATION_DS_MM);
        let area_mm2 = windowed_area_of_lists(stations.s_mm(), &volumes, window_mm);
        let reference_loads = reference_loads_of_record(
            &record,
            &moves,
            &area_mm2,
            stations.s_mm(),
            |k| &tools.entries[usize::from(engagement.tool_index[k])].model,
            (&steps, stock.grid().spacing_mm),
        );
        let swept = swept.filter(|_| matches!(surface, SurfaceFrom::Stock));
        let surface_angle_deg = surface_angles_deg(
            &stations,
            swept.as_ref(),
            stock.grid().spacing_mm,
            tools,
            &engagement.tool_index,
            &area_mm2,
            surface,
        );
        let held = Engagement {
            area_mm2,
            reference_loads,
            tool_index: engagement.tool_index.clone(),
            surface_angle_deg,
        };
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let load_bits = |l: &[ReferenceLoad]| {
            l.iter()
                .flat_map(|r| [r.force_peak_n, r.deflection_um, r.power_w, r.stress_mpa])
                .map(f64::to_bits)
                .collect::<Vec<_>>()
        };
        let cap_bits = |c: &[(f64, CapKind)]| {
            c.iter()
                .map(|&(v, kind)| (v.to_bits(), kind))
                .collect::<Vec<_>>()
        };
        let what = format!("memory budget {budget_mb:?}");
        assert_eq!(bits(&engagement.area_mm2), bits(&held.area_mm2), "{what}");
        assert_eq!(
            load_bits(&engagement.reference_loads),
            load_bits(&held.reference_loads),
            "{what}"
        );
        assert_eq!(
            bits(&engagement.surface_angle_deg),
            bits(&held.surface_angle_deg),
            "{what}"
        );
        let caps = caps_in_one_piece(&held, &stations, limits, tools);
        assert_eq!(
            cap_bits(&interval_caps(&engagement, &stations, limits, tools)),
            cap_bits(&caps),
            "{what}"
        );
        assert_eq!(
            cap_bits(
                &engagement_caps_on(&stations, &stock, tools, limits, surface)
                    .unwrap()
                    .0
            ),
            cap_bits(&caps),
            "{what}"
        );
        // What the comparison covers: every tool cuts, with its own
        // band count; intervals before the first cut take its shape;
        // the limits and S3 each set caps.
        assert_eq!(tools.entries.len(), 3);
        let n = moves.len();
        for t in 0..3u16 {
            assert!(
                (0..n).any(|j| move_tools[j] == t && record.volume_mm3(j) > 0.0),
                "tool {t} cuts ({what})"
            );
        }
        assert_eq!(record.n_bands, 24);
        let first_cut = moves
            .intervals((0..n).position(|j| record.volume_mm3(j) > 0.0).unwrap())
            .start;
        assert!(held.area_mm2[first_cut - 1] > 0.0, "{what}");
        assert!(
            held.reference_loads[first_cut - 1].force_peak_n > 0.0,
            "{what}"
        );
        // The moves sweep what the intervals one by one do: the same stock,
        // but for columns whose centres lie on a tool's rim (at its radius
        // from a move's line, to 1e-6 mm in XY), where cutting or not is
        // decided by rounding; the same removal in all to those columns.
        let (by_interval, interval_record) = crate::run::sweep_pass(
            &stock.initial(),
            None,
            tools,
            &engagement.tool_index,
            &steps,
            &options,
            "engagement",
        )
        .unwrap();
        let total = |r: &dexel::RemovalRecord| (0..r.len()).map(|j| r.volume_mm3(j)).sum::<f64>();
        let (a, b) = (total(&record), total(&interval_record));
        assert!(
            a > 100.0 && (a - b).abs() <= 1e-4 * b,
            "{a} against {b} mm³ ({what})"
        );
        if let (Some(x), Some(y)) = (swept.as_ref(), by_interval.as_ref()) {
            let g = x.grid();
            let radii: Vec<f64> = tools.entries.iter().map(|e| e.tool.radius_mm()).collect();
            let on_a_rim = |px: f64, py: f64| {
                move_steps.iter().zip(&move_tools).any(|(st, &t)| {
                    let (a, b) = (st.from_mm, st.to_mm);
                    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                    let l2 = dx * dx + dy * dy;
                    let u = if l2 > 0.0 {
                        (((px - a[0]) * dx + (py - a[1]) * dy) / l2).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let d = (px - a[0] - u * dx).hypot(py - a[1] - u * dy);
                    (d - radii[usize::from(t)]).abs() <= 1e-6
                })
            };
            let mut ties = 0;
            for (i, (p, q)) in x.top_heights().iter().zip(y.top_heights()).enumerate() {
                // (A move across a junction sweeps its chord: within
                // JOIN_TOL_MM of the intervals', and of their f32 heights.)
                let chord_mm =
                    super::engagement::JOIN_TOL_MM + 4.0 * f64::from(f32::EPSILON * q.abs());
                if *p != q && f64::from((p - q).abs()) > chord_mm {
                    let (px, py) = (g.x_mm(i % g.nx), g.y_mm(i / g.nx));
                    assert!(
                        on_a_rim(px, py),
                        "column ({px}, {py}): {p} against {q} mm ({what})"
                    );
                    ties += 1;
                }
            }
            assert!(ties < g.len() / 100, "{ties} columns differ ({what})");
        }
        assert!(steps.iter().any(|s| s.rapid));
        assert!(steps
            .iter()
            .any(|s| s.from_mm[..2] == s.to_mm[..2] && s.from_mm[2] != s.to_mm[2]));
        let kinds: std::collections::BTreeSet<String> =
            caps.iter().map(|c| format!("{:?}", c.1)).collect();
        for kind in ["Removal", "Deflection", "ChipLoad", "FeedScale", "FeedMax"] {
            assert!(kinds.contains(kind), "{kind} in {kinds:?} ({what})");
        }
        // With a force limit at a tenth of the median reference peak, the force caps
        // hold part of the path: the caps made with the peak only where it
        // can be the cap (MODEL.md §3.4, "A bound on the peak") are those of
        // every interval's peak, bit for bit, on both sides of that line.
        let mut peaks: Vec<f64> = held
            .reference_loads
            .iter()
            .map(|l| l.force_peak_n)
            .filter(|&f| f > 0.0)
            .collect();
        peaks.sort_by(f64::total_cmp);
        let low = LimitsSpec {
            force_max: Some(0.1 * peaks[peaks.len() / 2]),
            ..limits.clone()
        };
        let exact = caps_in_one_piece(&held, &stations, &low, tools);
        assert_eq!(
            cap_bits(
                &engagement_caps_on(&stations, &stock, tools, &low, surface)
                    .unwrap()
                    .0
            ),
            cap_bits(&exact),
            "{what}"
        );
        let held_by = |kind: CapKind| exact.iter().filter(|c| c.1 == kind).count();
        assert!(
            held_by(CapKind::Force) > exact.len() / 20 && held_by(CapKind::Removal) > 0,
            "force {} removal {} of {} ({what})",
            held_by(CapKind::Force),
            held_by(CapKind::Removal),
            exact.len()
        );
        if budget_mb.is_none() {
            assert!(kinds.contains("SurfaceAngle"), "{kinds:?}");
        }
    }
}

#[test]
fn windowed_area_is_conservative_and_exact_on_plateaus() {
    // 0.05 mm intervals; volume alternates 0 / 3 (quantised 30 mm³/mm) from s = 2 to 6.
    let s: Vec<f64> = (0..=200).map(|i| i as f64 * 0.05).collect();
    let v: Vec<f64> = (0..200)
        .map(|i| {
            if (40..120).contains(&i) {
                if i % 2 == 0 {
                    3.0
                } else {
                    0.0
                }
            } else {
                0.0
            }
        })
        .collect();
    let a = windowed_area(&s, &v, 0.2);
    assert!((a[80] - 30.0).abs() < 1e-9, "plateau {}", a[80]);
    // The cap starts one window (4 intervals) before the rise and ends one window after.
    assert!(a[36] > 0.0 && a[35] == 0.0, "{:?}", &a[34..42]);
    // (the last non-zero interval is 118: the pattern alternates).
    assert!(a[122] > 0.0 && a[123] == 0.0, "{:?}", &a[118..126]);
    // Never below the plain mean over any window.
    assert!(a.iter().all(|x| *x <= 30.0 + 1e-9));
}

/// S3's stretches: adjacent intervals with one cap are one stretch; a step
/// takes the highest cap of the stretches it runs over, and none where part
/// of it lies outside them (air, no surface angle).
#[test]
fn feed_rules_give_a_step_the_highest_cap_it_runs_over_where_they_cover_it() {
    let mut rules = FeedRules::default();
    assert!(rules.is_empty());
    rules.push_angle(0.0, 1.0, 300.0);
    rules.push_angle(1.0, 2.0, 300.0);
    rules.push_angle(2.0, 3.0, 500.0);
    rules.push_angle(4.0, 5.0, 200.0);
    assert_eq!(
        rules.angle,
        [(0.0, 2.0, 300.0), (2.0, 3.0, 500.0), (4.0, 5.0, 200.0)]
    );
    assert_eq!(rules.angle_cap(0.2, 1.5), Some(300.0));
    assert_eq!(rules.angle_cap(1.5, 2.5), Some(500.0));
    assert_eq!(rules.angle_cap(3.0, 3.5), None);
    assert_eq!(rules.angle_cap(2.5, 4.5), None);
    assert_eq!(rules.angle_cap(4.0, 5.0), Some(200.0));
    assert_eq!(rules.angle_cap(4.5, 5.5), None);
    assert_eq!(rules.angle_cap(-0.5, 0.5), None);
}

/// The engagement sweep's moves cross a junction only where the path keeps
/// to their chord: not where it turns back along its line (a feed in and out
/// of the same hole, a pass and its return), whose turning station a chord
/// across it would not reach; they do where two blocks lie 0.1 µm off one
/// line.
#[test]
fn engagement_moves_do_not_cross_a_turn_back() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("job.toml"),
        "[stock]\nkind = \"box\"\nmin = [0, 0, 0]\nmax = [60, 40, 20]\ngrid = 0.1\n\
         [tool]\nkind = \"flat\"\ndiameter = 6\n\
         [program]\npath = \"p.ngc\"\n[cutting]\nmaterial = \"al6061\"\n\
         [machine]\nfeed_max = 3000\naccel = [1000, 1000, 1000]\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("p.ngc"),
        "G21 G90 G17\nS9000 M3\nG0 X5 Y20 Z25\nG1 Z12.07 F600\nG1 Z15\nG1 X19.93 F1200\n\
         G1 X10\nG1 X30.03 Y20.0001\nG1 X50 Y20\nG0 Z25\nM2\n",
    )
    .unwrap();
    let setup = Setup::load(&dir.path().join("job.toml"), None).unwrap();
    let machine = optimising_machine(&setup.machine, &setup.job.limits);
    let stations = free_stations(&setup.program.path, &machine).unwrap();
    let moves = SweepMoves::new(&stations, setup.stock.grid().spacing_mm);
    let at = |k: usize| stations.position_at(k);
    // Each turn back (the plunge's bottom at Z12.07, the pass's end at
    // X19.93: neither a whole number of moves from its block's start) is a
    // station where a move ends; the junction at X30.03 is crossed.
    let ends: Vec<usize> = (0..moves.len()).map(|j| moves.intervals(j).end).collect();
    let station_at = |x: f64, z: f64| {
        (0..stations.len())
            .find(|&k| (at(k).x - x).abs() < 1e-9 && (at(k).z - z).abs() < 1e-9)
            .unwrap_or_else(|| panic!("a station at X{x} Z{z}"))
    };
    for (x, z) in [(5.0, 12.07), (19.93, 15.0)] {
        let k = station_at(x, z);
        assert!(
            ends.contains(&k),
            "a move crosses the turn back at X{x} Z{z}"
        );
    }
    let k = (0..stations.len())
        .find(|&k| (at(k).x - 30.03).abs() < 1e-9 && (at(k).y - 20.0001).abs() < 1e-9)
        .expect("the junction at X30.03");
    assert!(
        (0..moves.len()).any(|j| {
            let r = moves.intervals(j);
            r.start < k && k < r.end
        }),
        "no move crosses the junction 0.1 µm off the line"
    );
}
