//! Drawing a rig from its seed.

use crate::rng::{stream, Rand};
use crate::{
    ControllerSpec, CylinderSpec, FluidSpec, FrictionSpec, LoadSpec, RigSpec, SensorSpec,
    SupplySpec, ValveSpec,
};

pub(crate) fn random(seed: u64, supply_bar: f64, temp_c: f64) -> RigSpec {
    let load = LoadSpec::random(&mut Rand::new(seed, stream::LOAD));
    let nominal_mass = load.effective_mass_kg(0.09);
    RigSpec {
        seed,
        supply_bar,
        temp_c,
        load,
        cylinder: CylinderSpec::random(&mut Rand::new(seed, stream::CYLINDER), nominal_mass),
        fluid: FluidSpec::random(&mut Rand::new(seed, stream::FLUID)),
        valve: ValveSpec::random(&mut Rand::new(seed, stream::VALVE)),
        friction: FrictionSpec::random(&mut Rand::new(seed, stream::FRICTION), nominal_mass),
        supply: SupplySpec::random(&mut Rand::new(seed, stream::SUPPLY)),
        sensors: SensorSpec::random(&mut Rand::new(seed, stream::SENSORS)),
        controller: ControllerSpec::random(&mut Rand::new(seed, stream::CONTROLLER)),
    }
}
