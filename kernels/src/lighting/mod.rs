//! Lighting at secondary hits: the light grid ([`light_grid`], "UpdateLightGrid"), the shadow
//! rays of "GenerateReservoirs" ([`reservoirs`]: temporal radiance feedback, else RIS through the
//! light grid) and world-space ReSTIR's temporal reuse ([`restir`]).

pub mod light_grid;
pub mod reservoirs;
pub mod restir;
