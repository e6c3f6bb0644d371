//! A plunge's contact resultant (MODEL.md §1.4): zero where the tool is
//! engaged evenly all round, whatever the lattice's phase under the axis, and
//! the half disc's 2/π of the volume where only one side is engaged.

use std::f64::consts::PI;

use dexel::{sweep, Step, Stock, SweepOptions, Tool};

fn plunges(x: f64, y: f64, from_z: f64, depths: &[f64]) -> Vec<Step> {
    let mut z = from_z;
    depths
        .iter()
        .map(|&to| {
            let s = Step {
                from_mm: [x, y, z],
                to_mm: [x, y, to],
                rapid: false,
            };
            z = to;
            s
        })
        .collect()
}

/// The pcb2gcode drill job of BENCHMARKS.md: a Ø0.4 mm flat end on a 0.05 mm
/// grid whose columns are not symmetric about the hole's axis (it recorded
/// a resultant of 3.9 % of the volume, 0.47 N sideways on a 3 N plunge).
/// A flat end cuts every column under it evenly from the first step; a ball
/// from the step after the one that buries it to its radius (from the third:
/// 0.12 mm and 0.32 mm deep before it).
#[test]
fn an_even_plunge_records_no_resultant() {
    let depths: Vec<f64> = (1..=8).map(|k| 0.08 - 0.2 * k as f64).collect();
    for (tool, centre, first) in [
        (Tool::flat(0.4), [22.86, -11.43], 0),
        (Tool::flat(0.4), [41.91, -13.97], 0),
        (Tool::ball(0.4), [41.91, -20.32], 2),
        (Tool::flat(3.0), [10.013, -7.0071], 0),
    ] {
        let mut stock = Stock::new_box([-2.2, -22.52, -2.6], [44.11, 2.2, 0.0], 0.05).unwrap();
        let steps = plunges(centre[0], centre[1], 0.08, &depths);
        let record = sweep(&mut stock, &tool, &steps, &SweepOptions::default(), &|_| {}).unwrap();
        for i in first..steps.len() {
            let v = record.volume_mm3(i);
            let [cx, cy] = record.contact_resultant(i);
            assert!(v > 0.0, "step {i} of {tool:?} removes nothing");
            // Column heights are f32: an even cut is even to about 1e-7 mm.
            assert!(
                cx.hypot(cy) <= 1e-6 * v,
                "{:?} at {centre:?}, step {i}: resultant {cx:e}, {cy:e} for {v} mm³",
                tool.shape
            );
        }
    }
}

/// A flat end plunging on the edge of the stock (the axis on its face) cuts
/// a half disc: the resultant is ∫ r̂ dA over the half disc, 2/π of the volume
/// towards the material.
#[test]
fn a_plunge_on_the_edge_records_the_half_disc() {
    let mut stock = Stock::new_box([10.0, -10.0, -5.0], [30.0, 10.0, 0.0], 0.02).unwrap();
    let steps = plunges(10.0, 0.0037, 1.0, &[-1.0, -2.0]);
    let tool = Tool::flat(4.0);
    let record = sweep(&mut stock, &tool, &steps, &SweepOptions::default(), &|_| {}).unwrap();
    for i in 0..2 {
        let v = record.volume_mm3(i);
        let [cx, cy] = record.contact_resultant(i);
        let rel = (cx / v - 2.0 / PI).abs() / (2.0 / PI);
        assert!(rel < 2e-3, "step {i}: {} vs 2/π (error {rel:.1e})", cx / v);
        assert!(cy.abs() < 2e-3 * v, "step {i}: {cy} across for {v} mm³");
    }
}
