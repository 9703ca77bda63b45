//! The pore fluid's temperature on the CPU, part of the `pore_flow` stage when the heat field
//! is on too (the plan's pore flow is `thermal`): the fluid's temperatures fitted to the grains
//! when they have none, and after the flow's sub-steps (which carry the heat upwind and hold the
//! regions' temperatures, `effects/pore_flow/flow.rs`) the exchange with the elements at the pores' corners
//! (`effects/pore_flow/fluid_temperature.rs`). GPU twin: `effects/pore_flow/gpu/heat.rs` (shaders/pore_heat.wgsl).

use crate::effects::pore_flow::PoreFlow;
use crate::error::Result;
use crate::model::Model;

/// Gives the fluid its temperatures when it has none (and the model's thermal lanes their
/// length): before the flow.
pub fn fit(m: &mut Model, f: &mut PoreFlow) {
    m.fit_thermal();
    f.fit_temperature(m);
}

/// Exchanges heat between the fluid and the grains for one mechanical step: after the flow,
/// before the pressure forces (which see the pressures at the new temperatures).
pub fn exchange(m: &mut Model, f: &mut PoreFlow) -> Result<()> {
    let dt = m.clock.dt;
    f.exchange_heat(m, dt)
}
