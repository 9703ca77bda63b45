//! The model stays on the device between runs: a run continues the device's session when the
//! model is as the last run left it, and uploads it afresh after any change a program made.

use crate::common::{gpu, material};
use crate::gpu_parity::{oedometer_sample, pulled_bonded_block};
use matdem_engine::backend::gpu::device::GpuContext;
use matdem_engine::backend::gpu::{GpuBackend, RowStats};
use matdem_engine::backend::RunControl;
use matdem_engine::simulation::run_steps;
use matdem_engine::{Model, Vec3, WallMotion};
use std::sync::Arc;

/// Runs `m` on a backend of its own, `runs` runs of `steps` each; returns the row statistics.
fn runs(ctx: &Arc<GpuContext>, m: &mut Model, runs: u64, steps: u64) -> RowStats {
    let mut backend = GpuBackend::prepare(ctx.clone(), m).unwrap();
    for _ in 0..runs {
        run_steps(&mut backend, m, steps, 0, &RunControl::default(), &mut |_| {}, &mut |_| {}).unwrap();
    }
    backend.row_stats().clone()
}

fn bits(v: &[Vec3]) -> Vec<[u64; 3]> {
    v.iter().map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()]).collect()
}

fn heat(m: &Model) -> f64 {
    m.particles.heat.lanes().iter().map(|l| l.iter().sum::<f64>()).sum()
}

// A servo platen pressing 64 grains in a ring: 1,000 steps as one run, and as ten runs of 100
// (each ending in a sync, as a script's balance does every 100 steps). The ten continue on
// the device after one upload, and the grains end bitwise where the one run puts them; the
// platen's travel and the heat ledger, which each sync adds to in f64, agree to 1e-12 and
// 1e-6. Before the model stayed on the device, every run uploaded it, and the f32 origin of
// each upload changed the trajectory's last bits.
#[test]
fn runs_that_continue_on_the_device_equal_one_run() {
    let Some(ctx) = gpu("resident_runs") else { return };
    let mut model = oedometer_sample();
    model.wall_mut("top_platen").unwrap().motion = WallMotion::Servo { stress: 2e4, max_speed: 0.2 };
    let (mut one, mut ten) = (model.clone(), model);
    let a = runs(&ctx, &mut one, 1, 1000);
    let b = runs(&ctx, &mut ten, 10, 100);
    assert_eq!((a.uploads, a.continued), (1, 0));
    assert_eq!((b.uploads, b.continued), (1, 9), "{b:?}");
    assert_eq!(one.clock.step, ten.clock.step);
    let (p, q) = (&one.particles, &ten.particles);
    assert!(bits(&p.pos) == bits(&q.pos) && bits(&p.vel) == bits(&q.vel), "the grains differ");
    let travel = |m: &Model| m.walls[2].displacement.z;
    eprintln!("platen travel {:e} / {:e} m, heat {:e} / {:e} J", travel(&one), travel(&ten), heat(&one), heat(&ten));
    assert!(travel(&one) < -1e-5, "the platen moves");
    assert!((travel(&ten) - travel(&one)).abs() <= 1e-12 * travel(&one).abs());
    assert!(heat(&one) > 0.0 && (heat(&ten) - heat(&one)).abs() <= 1e-6 * heat(&one));
}

// A bonded block pulled apart: the bonds that break during ten runs of 300 steps are those of
// one run of 3,000, at the same steps (each run's events are taken once, counted from its
// own start).
#[test]
fn breakages_across_continued_runs_are_those_of_one_run() {
    let Some(ctx) = gpu("resident_breakages") else { return };
    let m = pulled_bonded_block(3, 3);
    let (mut one, mut ten) = (m.clone(), m);
    runs(&ctx, &mut one, 1, 3000);
    let b = runs(&ctx, &mut ten, 10, 300);
    assert_eq!(b.continued, 9, "{b:?}");
    assert!(!one.breakages.is_empty(), "the pull must break bonds");
    let key = |m: &Model| m.breakages.iter().map(|x| (x.step, x.i, x.j)).collect::<Vec<_>>();
    assert_eq!(key(&one), key(&ten));
}

// A change between runs reaches the device: after a run, one grain's velocity is set on the
// host. The next run uploads the model again, and ends bitwise where a new backend started
// from the changed model ends.
#[test]
fn a_change_between_runs_is_uploaded() {
    let Some(ctx) = gpu("resident_change") else { return };
    let mut m = Model::new();
    m.settings.gravity = Vec3::new(0.0, 0.0, -9.81);
    let k = m.add_material(material("sand", 2650.0, 1e5, 5e7, 0.25)).unwrap();
    for x in matdem_engine::builder::simple_cubic(3, 3, 3, 2.1e-3, Vec3::repeat(1e-3)) {
        m.add_particle(x, 1e-3, k).unwrap();
    }
    m.set_standard_dt().unwrap();
    let mut backend = GpuBackend::prepare(ctx.clone(), &m).unwrap();
    let go = |b: &mut GpuBackend, m: &mut Model| {
        run_steps(b, m, 200, 0, &RunControl::default(), &mut |_| {}, &mut |_| {}).unwrap();
    };
    go(&mut backend, &mut m);
    m.particles.vel[13] = Vec3::new(0.3, 0.0, 0.0);
    let mut fresh = m.clone();
    go(&mut backend, &mut m);
    assert_eq!((backend.row_stats().uploads, backend.row_stats().continued), (2, 0));
    let mut other = GpuBackend::prepare(ctx.clone(), &fresh).unwrap();
    go(&mut other, &mut fresh);
    assert!(m.particles.pos[13].x > fresh.particles.pos[0].x, "the grain was pushed");
    assert!(bits(&m.particles.pos) == bits(&fresh.particles.pos), "the change did not reach the device");
}
