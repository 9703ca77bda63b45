//! The GPU backend: the CPU backend's stages as WGSL compute kernels (wgpu), in f32.
//!
//! A run uploads the model once, steps it on the device in batches of command buffers, and
//! brings back only what the host needs: between batches a few counters (the largest drift
//! and speed, the guard's findings), at the end of the run the state a script reads. One
//! step dispatches, in order: walls (last step's loads summed, then moved) → contact forces →
//! wall forces → integration. Pipelines are built once per plan, with the plan's laws as pipeline
//! constants; stages the scene does not need (walls) are neither built nor dispatched, and
//! lanes it does not need (rotation, the dashpot force, heat causes it cannot produce) are
//! 128-byte placeholders or absent.
//!
//! Deterministic: each particle sums its own row and writes only its own lanes; wall loads
//! are reduced in a fixed tree order; the only atomics count integers (breakage events,
//! sorted on the host; drift maxima; guard minima). Two runs give the same bits.
//!
//! Heat is booked on the device by cause, as the CPU books it (each row half of every pair's
//! heat), into compensated f32 sums that each download adds to the model's f64 ledger
//! ([`heat`]).
//!
//! Not done on the device (the host keeps them): building neighbour rows (see
//! [`neighbours`]) and energy samples (the state comes back to the host for each sample).

pub mod buffers;
pub mod contact_forces;
pub mod device;
pub mod guard;
pub mod heat;
pub mod integrate;
pub mod neighbours;
pub mod shaders;
pub mod wall_forces;
pub mod walls;

use crate::backend::cpu::neighbours::{is_stale, rebuild};
use crate::backend::RunControl;
use crate::error::{Error, GpuError, Result};
use crate::model::{Breakage, Model};
use crate::physics::contact_law::BreakKind;
use crate::plan::StepPlan;
use buffers::{download, read, DeviceLanes, HostLanes, Params, COUNTERS, C_DRIFT, C_EVENTS, C_GUARD, C_SPEED};
use device::GpuContext;
use shaders::Kernel;
use std::sync::{Arc, Mutex};

pub use device::{select, BackendChoice, Compute};

/// Steps one batch may hold before the host looks at the drift again.
const MAX_BATCH: u64 = 64;

struct Pipelines {
    drift: wgpu::ComputePipeline,
    contact: wgpu::ComputePipeline,
    /// Walls (loads summed, then moved), wall forces, loads summed alone: only with walls.
    walls: Option<[wgpu::ComputePipeline; 3]>,
    integrate: wgpu::ComputePipeline,
    guard: wgpu::ComputePipeline,
}

struct Kernels {
    drift: Kernel,
    contact: Kernel,
    walls: Option<[Kernel; 3]>,
    integrate: Kernel,
    guard: Kernel,
}

/// The model on the device, from an upload to the next download.
struct Session {
    host: HostLanes,
    lanes: DeviceLanes,
    kernels: Kernels,
    /// Steps run since the upload.
    steps: u64,
}

/// A plan's pipelines on one device.
pub struct GpuBackend {
    ctx: Arc<GpuContext>,
    pub plan: StepPlan,
    pipelines: Pipelines,
    /// c_i/m_i of the viscous damping (empty when off).
    damping_rate: Vec<f64>,
    /// Bytes of the device buffers of the last run.
    device_bytes: u64,
    /// The heat ledger's slots.
    ledger: heat::Layout,
    /// The first error the device reported outside a call (wgpu's uncaptured errors).
    errors: Arc<Mutex<Option<String>>>,
}

impl GpuBackend {
    /// Builds the pipelines the model's plan needs.
    pub fn prepare(ctx: Arc<GpuContext>, m: &Model) -> Result<Self> {
        let plan = StepPlan::build(m);
        let errors = Arc::new(Mutex::new(None::<String>));
        let sink = errors.clone();
        ctx.device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let mut slot = sink.lock().unwrap_or_else(|p| p.into_inner());
            if slot.is_none() {
                // Display carries the chain of causes (Debug would add the whole shader).
                *slot = Some(e.to_string());
            }
        }));
        let device = &ctx.device;
        let ledger = heat::Layout::for_plan(&plan);
        let mut constants = shaders::constants(&plan);
        constants.extend(ledger.constants());
        let pipelines = Pipelines {
            drift: neighbours::pipeline(device, &constants),
            contact: contact_forces::pipeline(device, &constants),
            walls: (plan.walls > 0).then(|| {
                [
                    walls::pipeline(device, &constants),
                    wall_forces::pipeline(device, &constants),
                    walls::sum_pipeline(device, &constants),
                ]
            }),
            integrate: integrate::pipeline(device, &constants),
            guard: guard::pipeline(device, &constants),
        };
        let damping_rate = if plan.damping > 0.0 {
            (0..m.len())
                .map(|i| {
                    let mass = m.particles.mass[i];
                    2.0 * plan.damping * (mass * m.element_stiffness(i)).sqrt() / mass
                })
                .collect()
        } else {
            Vec::new()
        };
        let backend = GpuBackend { ctx, plan, pipelines, damping_rate, device_bytes: 0, errors, ledger };
        backend.check_device()?;
        Ok(backend)
    }

    /// The adapter, in words.
    pub fn device_name(&self) -> String {
        self.ctx.describe()
    }

    /// Bytes of device memory the last run used.
    pub fn device_bytes(&self) -> u64 {
        self.device_bytes
    }

    fn check_device(&self) -> Result<()> {
        match self.errors.lock().unwrap_or_else(|p| p.into_inner()).take() {
            Some(e) => Err(GpuError::Device(e).into()),
            None => Ok(()),
        }
    }

    /// Runs `steps` steps on the device: the guard every `guard_every` steps,
    /// `progress(done)` and cancellation between guard chunks, and `sample(model)` at the
    /// start of every `every`-th step (0 = never), with the model brought up to date.
    pub fn run(
        &mut self,
        m: &mut Model,
        steps: u64,
        every: u64,
        ctl: &RunControl,
        progress: &mut dyn FnMut(u64),
        sample: &mut dyn FnMut(&mut Model),
    ) -> Result<()> {
        let guard_every = m.settings.guard_every.max(1);
        let mut session = self.upload(m)?;
        let mut done = 0;
        let mut batch = 1;
        while done < steps {
            if every > 0 && done % every == 0 {
                self.download(m, session)?;
                sample(m);
                session = self.upload(m)?;
            }
            let until_guard = guard_every - done % guard_every;
            let until_sample = if every > 0 { every - done % every } else { u64::MAX };
            let k = batch.min(until_guard).min(until_sample).min(steps - done);
            let guard_now = (done + k) % guard_every == 0 || done + k == steps;
            let counters = self.step_batch(&session, k, guard_now)?;
            done += k;
            session.steps += k;
            if guard_now {
                let failed = (0..4).find(|&s| counters[C_GUARD + s] != u32::MAX);
                if let Some(slot) = failed {
                    let particle = counters[C_GUARD + slot] as usize;
                    self.download(m, session)?;
                    // The CPU guard words it (and finds the same particle, unless f32 and
                    // f64 disagree at the threshold: then the device's finding stands).
                    crate::guard::check_state(m)?;
                    return Err(crate::guard::unstable(m, particle, guard::FAILURES[slot].to_string()));
                }
                progress(done);
                if ctl.is_cancelled() {
                    self.download(m, session)?;
                    return Err(Error::Cancelled { completed_steps: done });
                }
            }
            let drift = f64::from(f32::from_bits(counters[C_DRIFT])).sqrt();
            let speed = f64::from(f32::from_bits(counters[C_SPEED])).sqrt();
            if !(drift.is_finite() && speed.is_finite()) {
                self.download(m, session)?;
                crate::guard::check_state(m)?;
                return Err(crate::guard::unstable(m, 0, guard::FAILURES[0].to_string()));
            }
            match neighbours::steps_until_rebuild(drift, speed, m.contacts.skin, m.clock.dt, MAX_BATCH) {
                Some(k) => batch = k,
                None => {
                    self.download(m, session)?;
                    rebuild(m);
                    session = self.upload(m)?;
                    batch = 1;
                }
            }
        }
        self.download(m, session)
    }

    /// Puts the model on the device (rows rebuilt first if they do not cover it).
    fn upload(&mut self, m: &mut Model) -> Result<Session> {
        if is_stale(&m.contacts, &m.particles.pos) {
            rebuild(m);
        }
        if self.plan.rotation && m.particles.rotation.is_none() {
            m.particles.enable_rotation();
        }
        if m.wall_contacts.len() != m.len() * m.walls.len() {
            return Err(Error::InvalidScene("wall contact states do not match the walls: rebuild the model".into()));
        }
        let host = HostLanes::from_model(m, &self.plan, &self.damping_rate, self.ledger.lanes());
        let wall_groups = wall_forces::partial_groups(m.len());
        let params = Params {
            n: m.len() as u32,
            nw: m.walls.len() as u32,
            nmat: self.plan.materials as u32,
            max_events: host.bonds.max(1) as u32,
            dt: m.clock.dt as f32,
            local_damping: m.settings.local_damping as f32,
            max_overlap_ratio: m.settings.max_overlap_ratio as f32,
            wall_groups: wall_groups as u32,
            gravity: [m.settings.gravity.x as f32, m.settings.gravity.y as f32, m.settings.gravity.z as f32, 0.0],
            one: 1.0,
            pad: [0.0; 3],
        };
        let lanes = DeviceLanes::upload(&self.ctx, &host, params, wall_groups)?;
        let device = &self.ctx.device;
        let p = &self.pipelines;
        let kernels = Kernels {
            drift: neighbours::kernel(device, &p.drift, &lanes),
            contact: contact_forces::kernel(device, &p.contact, &lanes),
            walls: p.walls.as_ref().map(|[a, f, l]| {
                [
                    walls::kernel(device, a, &lanes),
                    wall_forces::kernel(device, f, &lanes),
                    walls::kernel(device, l, &lanes),
                ]
            }),
            integrate: integrate::kernel(device, &p.integrate, &lanes),
            guard: guard::kernel(device, &p.guard, &lanes),
        };
        self.device_bytes = lanes.bytes;
        self.check_device()?;
        Ok(Session { host, lanes, kernels, steps: 0 })
    }

    /// Encodes `k` steps, the drift measure and (when `guard`) the guard's checks, submits
    /// them and reads the counters back.
    fn step_batch(&self, s: &Session, k: u64, guard: bool) -> Result<Vec<u32>> {
        let ctx = &self.ctx;
        let mut reset = [0u32; COUNTERS - C_DRIFT];
        reset[C_GUARD - C_DRIFT..].fill(u32::MAX);
        ctx.queue.write_buffer(&s.lanes.counters, (C_DRIFT * 4) as u64, bytemuck::cast_slice(&reset));
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            let kr = &s.kernels;
            for _ in 0..k {
                if let Some([advance, _, _]) = &kr.walls {
                    advance.dispatch(&mut pass);
                }
                kr.contact.dispatch(&mut pass);
                if let Some([_, forces, _]) = &kr.walls {
                    forces.dispatch(&mut pass);
                }
                kr.integrate.dispatch(&mut pass);
            }
            kr.drift.dispatch(&mut pass);
            if guard {
                kr.guard.dispatch(&mut pass);
            }
        }
        ctx.queue.submit([enc.finish()]);
        let counters = read::<u32>(ctx, &s.lanes.counters, COUNTERS)?;
        self.check_device()?;
        Ok(counters)
    }

    /// Brings the device's state into the model, appends the bonds that broke (in step and
    /// particle order, as the CPU backend records them) and advances the clock.
    fn download(&self, m: &mut Model, s: Session) -> Result<()> {
        if let (Some([_, _, loads]), true) = (&s.kernels.walls, s.steps > 0) {
            // The walls hold the loads of the step before the last: sum the last step's.
            let mut enc = self.ctx.device.create_command_encoder(&Default::default());
            loads.dispatch(&mut enc.begin_compute_pass(&Default::default()));
            self.ctx.queue.submit([enc.finish()]);
        }
        download(&self.ctx, &s.lanes, &s.host, m, self.plan.rotation)?;
        self.ledger.fold(&self.ctx, &s.lanes, m)?;
        let counters = read::<u32>(&self.ctx, &s.lanes.counters, COUNTERS)?;
        let count = (counters[C_EVENTS] as usize).min(s.lanes.max_events);
        let mut events: Vec<[u32; 4]> = read(&self.ctx, &s.lanes.events, count)?;
        events.sort_unstable();
        let (step0, time0, dt) = (m.clock.step, m.clock.time, m.clock.dt);
        for [step, i, j, kind] in events {
            let kind = if kind == 1 { BreakKind::Tension } else { BreakKind::Shear };
            let step = u64::from(step);
            m.breakages.push(Breakage { step: step0 + step, time: time0 + step as f64 * dt, i, j, kind });
        }
        for _ in 0..s.steps {
            m.clock.step += 1;
            m.clock.time += dt;
        }
        self.check_device()
    }
}
