//! The simulated rig's hardware as data: everything physical the simulator
//! computes the rig from — cylinder, pantograph load, valve, oil, friction,
//! healthy leakage, supply and tank, sensor offsets.
//!
//! This data is the simulator's own. It is not the monitor's `Params` (a
//! test plant shares neither model code nor model data types with the
//! monitor): the load and the oil are `plant`'s specs, the rest are types
//! of this module. [`Rig::reference`] holds the reference thesis rig's
//! values as literal numbers (the values the monitor's nominal parameters
//! also start from, copied, not read from there). A rig is read from and
//! written to TOML (`host-sim simulate --rig` / `--dump-rig`); a file only
//! needs the fields it changes from the reference rig, except that the
//! `[load.pantograph]` and `[fluid.oil]` tables (`plant`'s specs), when
//! given, are given whole. Unknown fields are an error (typo guard).

use plant::{FluidSpec, LoadSpec};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// The hydraulic cylinder (63/30 × 180) and the oil volumes between it and
/// the valve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Cylinder {
    /// Piston (cap) side area, m².
    pub piston_area_m2: f64,
    /// Rod side (annulus) area, m².
    pub rod_side_area_m2: f64,
    /// Stroke, m; position 0 is fully retracted. End stops sit at 0 and at
    /// the stroke.
    pub stroke_m: f64,
    /// Oil volume on the piston side at position 0 (hose, valve port,
    /// manifold), m³.
    pub dead_volume_piston_m3: f64,
    /// Oil volume on the rod side at full extension, m³.
    pub dead_volume_rod_m3: f64,
}

impl Cylinder {
    /// The reference rig's cylinder.
    pub fn reference() -> Self {
        Self {
            piston_area_m2: 3.117e-3,
            rod_side_area_m2: 2.41e-3,
            stroke_m: 0.18,
            dead_volume_piston_m3: 2.0e-4,
            dead_volume_rod_m3: 2.0e-4,
        }
    }
}

/// The pantograph crane the cylinder moves: `plant`'s geometry and mass
/// properties, with scales on its weight and its inertia.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Load {
    /// Multiplies the rods' masses and inertias in the gravity load
    /// (unaccounted masses: paint, welds, bolts), dimensionless.
    pub gravity_scale: f64,
    /// Multiplies the rods' masses and inertias in the effective moving
    /// mass, dimensionless.
    pub inertia_scale: f64,
    /// Geometry (angle fits in degrees, lengths in m), masses (kg),
    /// inertias (kg·m²), payload at the tip (kg), constant force offset (N,
    /// positive opposes extension) and gravity (m/s²), in `plant`'s terms.
    pub pantograph: LoadSpec,
}

impl Load {
    /// The reference rig's crane: the thesis geometry and masses, slender
    /// bar inertias, no payload and no force offset.
    pub fn reference() -> Self {
        Self {
            gravity_scale: 1.0,
            inertia_scale: 1.0,
            // The thesis geometry as the independent plant states it; the
            // reference rig's own masses and (slender-bar) inertias.
            pantograph: LoadSpec {
                masses_kg: [6.12844, 15.36792, 13.62235, 87.92456],
                inertias_kg_m2: [0.070_673, 1.321_969, 0.879_096, 53.414_170],
                payload_kg: 0.0,
                force_offset_n: 0.0,
                ..LoadSpec::nominal()
            },
        }
    }

    /// The pantograph with masses and inertias multiplied by `scale`.
    pub(crate) fn scaled(&self, scale: f64) -> LoadSpec {
        let p = &self.pantograph;
        LoadSpec {
            masses_kg: p.masses_kg.map(|m| m * scale),
            inertias_kg_m2: p.inertias_kg_m2.map(|i| i * scale),
            ..p.clone()
        }
    }
}

/// The servo valve (Moog D633 class): spool dynamics, four metering edges
/// with a common overlap, laminar leakage across the covered edges.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Valve {
    /// Spool natural frequency, rad/s.
    pub natural_frequency_rad_s: f64,
    /// Spool damping ratio, dimensionless.
    pub damping_ratio: f64,
    /// Flow gain of the edges opened by positive spool travel (P→A, B→T),
    /// l/min per √bar at full opening: Q = K·opening·√Δp.
    pub flow_gain_extend_lpm_sqrt_bar: f64,
    /// Flow gain of the edges opened by negative spool travel (P→B, A→T),
    /// l/min per √bar at full opening.
    pub flow_gain_retract_lpm_sqrt_bar: f64,
    /// Multipliers on those flow gains per edge, P→A, B→T, P→B, A→T
    /// (metering edges that do not match), dimensionless.
    pub edge_gain: [f64; 4],
    /// Spool overlap as a fraction of full travel: an edge opens at
    /// |x_v| > overlap, from zero there.
    pub dead_zone: f64,
    /// Spool position at zero command (null bias), fraction of travel.
    pub null_offset: f64,
    /// Laminar leakage across each covered metering edge at the reference
    /// temperature, l/min per bar.
    pub edge_leak_lpm_per_bar: f64,
    /// Multipliers on that leakage per edge, P→A, A→T, P→B, B→T,
    /// dimensionless.
    pub edge_leak: [f64; 4],
    /// Pressure drop below which the orifice flow turns laminar, bar.
    pub laminar_dp_bar: f64,
}

impl Valve {
    /// The reference rig's valve: matched edges, 1.5 % overlap, no null
    /// bias.
    pub fn reference() -> Self {
        Self {
            natural_frequency_rad_s: 879.645_943,
            damping_ratio: 0.92,
            flow_gain_extend_lpm_sqrt_bar: 7.9025,
            flow_gain_retract_lpm_sqrt_bar: 7.4187,
            edge_gain: [1.0; 4],
            dead_zone: 0.015,
            null_offset: 0.0,
            edge_leak_lpm_per_bar: 3.3e-3,
            edge_leak: [1.0; 4],
            laminar_dp_bar: 1.0,
        }
    }
}

/// The oil: `plant`'s viscosity law and bulk modulus with entrained air,
/// and the temperature the rig's laminar coefficients refer to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Fluid {
    /// Oil temperature at which the valve's edge leakage, the seal and
    /// baseline external leakage and the viscous friction hold, °C; at
    /// other temperatures they scale with the viscosity.
    pub reference_temperature_c: f64,
    /// Viscosity at 40 °C (cSt) and its 25 → 40 °C ratio, bulk modulus of
    /// the air-free oil (bar), entrained air fraction at atmospheric
    /// pressure and the air's polytropic exponent, in `plant`'s terms.
    pub oil: FluidSpec,
}

impl Fluid {
    /// The reference rig's oil: ISO VG 46 whose viscosity falls by e^0.675
    /// (about half) from 25 to 40 °C, 16 000 bar, 1 % air, adiabatic.
    pub fn reference() -> Self {
        Self {
            reference_temperature_c: 25.0,
            oil: FluidSpec {
                viscosity_40c_cst: 46.0,
                viscosity_ratio_25_40: 1.964_032_975_969_847_2,
                bulk_modulus_bar: 16_000.0,
                air_fraction: 0.01,
                polytropic_exponent: 1.4,
            },
        }
    }
}

/// Cylinder and crane friction: Karnopp stick–slip with an exponential
/// Stribeck curve, F = (F_c + (F_brk − F_c)·e^(−c_v·|v|))·sign(v) + B·v.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Friction {
    /// Coulomb friction F_c, N.
    pub coulomb_n: f64,
    /// Breakaway (static) friction F_brk, N.
    pub breakaway_n: f64,
    /// Stribeck decay constant c_v, s/m.
    pub stribeck_s_per_m: f64,
    /// Viscous friction B at the reference temperature, N·s/m.
    pub viscous_ns_per_m: f64,
}

impl Friction {
    /// The reference rig's friction.
    pub fn reference() -> Self {
        Self {
            coulomb_n: 480.0,
            breakaway_n: 990.0,
            stribeck_s_per_m: 10.0,
            viscous_ns_per_m: 5000.0,
        }
    }
}

/// Leakage of the healthy rig, laminar, at the reference temperature (the
/// leaks a scenario adds come on top).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Leakage {
    /// Piston seal leakage, piston chamber → rod chamber, l/min per bar.
    pub seal_lpm_per_bar: f64,
    /// Baseline leakage from the rod chamber to tank, l/min per bar.
    pub external_lpm_per_bar: f64,
}

impl Leakage {
    /// The reference rig's leakage: a tight seal, nothing to tank.
    pub fn reference() -> Self {
        Self {
            seal_lpm_per_bar: 6.0e-3,
            external_lpm_per_bar: 0.0,
        }
    }
}

/// The supply and return lines at the valve (the supply set pressure is
/// the scenario's).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Supply {
    /// Supply pressure droop with 20 l/min drawn, bar (grows with the
    /// square of the flow).
    pub droop_bar: f64,
    /// Supply ripple amplitude, bar.
    pub ripple_bar: f64,
    /// Supply ripple frequency, Hz.
    pub ripple_hz: f64,
    /// Tank pressure at the valve at zero return flow, bar (gauge).
    pub tank_bar: f64,
    /// Rise of the tank pressure with 20 l/min returned, bar (grows with
    /// the square of the flow).
    pub tank_rise_bar: f64,
}

impl Supply {
    /// The reference rig's supply and return lines.
    pub fn reference() -> Self {
        Self {
            droop_bar: 1.5,
            ripple_bar: 0.15,
            ripple_hz: 190.0,
            tank_bar: 0.6,
            tank_rise_bar: 1.0,
        }
    }
}

/// Offsets of the rig's sensors: added to every reading (the scenario's
/// `SensorModel` adds lag, noise and quantisation).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorOffsets {
    /// Offsets of the supply, piston, rod and tank pressure readings, bar.
    pub pressure_offsets_bar: [f64; 4],
    /// Offset of the position reading, m.
    pub position_offset_m: f64,
}

/// Everything physical about one simulated rig. The scenario (supply set
/// pressure, oil temperature, leaks, motion, sensor noise) is separate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Rig {
    /// Cylinder geometry and dead volumes.
    pub cylinder: Cylinder,
    /// The crane the cylinder moves.
    pub load: Load,
    /// The servo valve.
    pub valve: Valve,
    /// The oil.
    pub fluid: Fluid,
    /// Friction.
    pub friction: Friction,
    /// Healthy leakage.
    pub leakage: Leakage,
    /// Supply and tank lines.
    pub supply: Supply,
    /// Sensor offsets.
    pub sensors: SensorOffsets,
}

macro_rules! reference_default {
    ($($t:ty),*) => {$(
        impl Default for $t {
            /// The reference rig's values ([`Self::reference`]).
            fn default() -> Self {
                Self::reference()
            }
        }
    )*};
}
reference_default!(Cylinder, Load, Valve, Fluid, Friction, Leakage, Supply, Rig);

impl Rig {
    /// The reference thesis rig, exact to its data sheet values and with
    /// ideal sensors (no offsets).
    pub fn reference() -> Self {
        Self {
            cylinder: Cylinder::reference(),
            load: Load::reference(),
            valve: Valve::reference(),
            fluid: Fluid::reference(),
            friction: Friction::reference(),
            leakage: Leakage::reference(),
            supply: Supply::reference(),
            sensors: SensorOffsets::default(),
        }
    }

    /// This rig with random rig-to-rig variation, as in a fleet of
    /// installations built to the same drawing: valve flow gains ±5 % (and
    /// per edge ±2 %), edge leakage ±30 %, friction ±15 %, moving mass
    /// ±3 %, entrained air 0.5–3 %, dead volumes ±10 %, sensor offsets
    /// ±0.3 bar and ±1 mm. The air fraction and the sensor offsets are
    /// drawn, not varied: this rig's own are replaced.
    pub fn perturbed(&self, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xA5A5);
        let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.random::<f64>();
        let mut r = self.clone();
        r.valve.flow_gain_extend_lpm_sqrt_bar *= u(0.95, 1.05);
        r.valve.flow_gain_retract_lpm_sqrt_bar *= u(0.95, 1.05);
        r.valve.edge_leak_lpm_per_bar *= u(0.7, 1.3);
        let f = u(0.85, 1.15);
        r.friction.coulomb_n *= f;
        r.friction.breakaway_n *= f * u(0.95, 1.05);
        r.friction.viscous_ns_per_m *= u(0.85, 1.15);
        let m = u(0.97, 1.03);
        r.load.inertia_scale *= m;
        r.load.gravity_scale *= m;
        r.fluid.oil.air_fraction = u(0.005, 0.03);
        r.cylinder.dead_volume_piston_m3 *= u(0.9, 1.1);
        r.cylinder.dead_volume_rod_m3 *= u(0.9, 1.1);
        for g in &mut r.valve.edge_gain {
            *g *= u(0.98, 1.02);
        }
        r.sensors = SensorOffsets {
            pressure_offsets_bar: [u(-0.3, 0.3), u(-0.3, 0.3), u(-0.3, 0.3), u(-0.3, 0.3)],
            position_offset_m: u(-0.001, 0.001),
        };
        r
    }

    /// Check that the simulator can compute this rig: every number finite,
    /// sizes, gains and the oil's properties in range, the moving mass
    /// positive over the stroke. Names the first field that is not.
    pub fn validate(&self) -> Result<(), String> {
        let (c, l, v, f, fr, lk, s) = (
            &self.cylinder,
            &self.load,
            &self.valve,
            &self.fluid,
            &self.friction,
            &self.leakage,
            &self.supply,
        );
        let p = &l.pantograph;
        let o = &f.oil;
        let mut finite: Vec<(&str, f64)> = vec![
            ("cylinder.piston_area_m2", c.piston_area_m2),
            ("cylinder.rod_side_area_m2", c.rod_side_area_m2),
            ("cylinder.stroke_m", c.stroke_m),
            ("cylinder.dead_volume_piston_m3", c.dead_volume_piston_m3),
            ("cylinder.dead_volume_rod_m3", c.dead_volume_rod_m3),
            ("load.gravity_scale", l.gravity_scale),
            ("load.inertia_scale", l.inertia_scale),
            ("load.pantograph.base_to_r21_y_m", p.base_to_r21_y_m),
            ("load.pantograph.r21_to_r1_m", p.r21_to_r1_m),
            ("load.pantograph.r21_to_r3_m", p.r21_to_r3_m),
            ("load.pantograph.r21_to_cg21_m", p.r21_to_cg21_m),
            ("load.pantograph.r1_to_cg1_m", p.r1_to_cg1_m),
            ("load.pantograph.r1_to_r22_m", p.r1_to_r22_m),
            ("load.pantograph.r22_to_cg22_m", p.r22_to_cg22_m),
            ("load.pantograph.r3_to_cg3_m", p.r3_to_cg3_m),
            ("load.pantograph.r3_to_tip_m", p.r3_to_tip_m),
            ("load.pantograph.payload_kg", p.payload_kg),
            ("load.pantograph.force_offset_n", p.force_offset_n),
            ("load.pantograph.gravity_m_s2", p.gravity_m_s2),
            ("valve.natural_frequency_rad_s", v.natural_frequency_rad_s),
            ("valve.damping_ratio", v.damping_ratio),
            (
                "valve.flow_gain_extend_lpm_sqrt_bar",
                v.flow_gain_extend_lpm_sqrt_bar,
            ),
            (
                "valve.flow_gain_retract_lpm_sqrt_bar",
                v.flow_gain_retract_lpm_sqrt_bar,
            ),
            ("valve.dead_zone", v.dead_zone),
            ("valve.null_offset", v.null_offset),
            ("valve.edge_leak_lpm_per_bar", v.edge_leak_lpm_per_bar),
            ("valve.laminar_dp_bar", v.laminar_dp_bar),
            ("fluid.reference_temperature_c", f.reference_temperature_c),
            ("fluid.oil.viscosity_40c_cst", o.viscosity_40c_cst),
            ("fluid.oil.viscosity_ratio_25_40", o.viscosity_ratio_25_40),
            ("fluid.oil.bulk_modulus_bar", o.bulk_modulus_bar),
            ("fluid.oil.air_fraction", o.air_fraction),
            ("fluid.oil.polytropic_exponent", o.polytropic_exponent),
            ("friction.coulomb_n", fr.coulomb_n),
            ("friction.breakaway_n", fr.breakaway_n),
            ("friction.stribeck_s_per_m", fr.stribeck_s_per_m),
            ("friction.viscous_ns_per_m", fr.viscous_ns_per_m),
            ("leakage.seal_lpm_per_bar", lk.seal_lpm_per_bar),
            ("leakage.external_lpm_per_bar", lk.external_lpm_per_bar),
            ("supply.droop_bar", s.droop_bar),
            ("supply.ripple_bar", s.ripple_bar),
            ("supply.ripple_hz", s.ripple_hz),
            ("supply.tank_bar", s.tank_bar),
            ("supply.tank_rise_bar", s.tank_rise_bar),
            ("sensors.position_offset_m", self.sensors.position_offset_m),
        ];
        let arrays: [(&str, &[f64]); 7] = [
            ("load.pantograph.theta1_fit_deg", &p.theta1_fit_deg),
            ("load.pantograph.theta2_fit_deg", &p.theta2_fit_deg),
            ("load.pantograph.masses_kg", &p.masses_kg),
            ("load.pantograph.inertias_kg_m2", &p.inertias_kg_m2),
            ("valve.edge_gain", &v.edge_gain),
            ("valve.edge_leak", &v.edge_leak),
            (
                "sensors.pressure_offsets_bar",
                &self.sensors.pressure_offsets_bar,
            ),
        ];
        for (name, values) in arrays {
            finite.extend(values.iter().map(|x| (name, *x)));
        }
        if let Some((name, x)) = finite.iter().find(|(_, x)| !x.is_finite()) {
            return Err(format!("{name} = {x} is not a finite number"));
        }
        let positive = [
            ("cylinder.piston_area_m2", c.piston_area_m2),
            ("cylinder.rod_side_area_m2", c.rod_side_area_m2),
            ("cylinder.stroke_m", c.stroke_m),
            ("cylinder.dead_volume_piston_m3", c.dead_volume_piston_m3),
            ("cylinder.dead_volume_rod_m3", c.dead_volume_rod_m3),
            ("load.gravity_scale", l.gravity_scale),
            ("load.inertia_scale", l.inertia_scale),
            ("valve.natural_frequency_rad_s", v.natural_frequency_rad_s),
            ("valve.damping_ratio", v.damping_ratio),
            ("valve.laminar_dp_bar", v.laminar_dp_bar),
            ("fluid.oil.viscosity_40c_cst", o.viscosity_40c_cst),
            ("fluid.oil.viscosity_ratio_25_40", o.viscosity_ratio_25_40),
            ("fluid.oil.bulk_modulus_bar", o.bulk_modulus_bar),
            ("fluid.oil.polytropic_exponent", o.polytropic_exponent),
        ];
        if let Some((name, x)) = positive.iter().find(|(_, x)| !(*x > 0.0)) {
            return Err(format!("{name} = {x} must be > 0"));
        }
        let mut non_negative: Vec<(&str, f64)> = vec![
            (
                "valve.flow_gain_extend_lpm_sqrt_bar",
                v.flow_gain_extend_lpm_sqrt_bar,
            ),
            (
                "valve.flow_gain_retract_lpm_sqrt_bar",
                v.flow_gain_retract_lpm_sqrt_bar,
            ),
            ("valve.edge_leak_lpm_per_bar", v.edge_leak_lpm_per_bar),
            ("load.pantograph.payload_kg", p.payload_kg),
            ("friction.coulomb_n", fr.coulomb_n),
            ("friction.breakaway_n", fr.breakaway_n),
            ("friction.stribeck_s_per_m", fr.stribeck_s_per_m),
            ("friction.viscous_ns_per_m", fr.viscous_ns_per_m),
            ("leakage.seal_lpm_per_bar", lk.seal_lpm_per_bar),
            ("supply.ripple_hz", s.ripple_hz),
        ];
        for (name, values) in [
            ("load.pantograph.masses_kg", &p.masses_kg[..]),
            ("load.pantograph.inertias_kg_m2", &p.inertias_kg_m2[..]),
            ("valve.edge_gain", &v.edge_gain[..]),
            ("valve.edge_leak", &v.edge_leak[..]),
        ] {
            non_negative.extend(values.iter().map(|x| (name, *x)));
        }
        if let Some((name, x)) = non_negative.iter().find(|(_, x)| *x < 0.0) {
            return Err(format!("{name} = {x} must be ≥ 0"));
        }
        if !(0.0..1.0).contains(&v.dead_zone) {
            return Err(format!(
                "valve.dead_zone = {} must be within 0..1",
                v.dead_zone
            ));
        }
        if !(0.0..1.0).contains(&o.air_fraction) {
            return Err(format!(
                "fluid.oil.air_fraction = {} must be within 0..1",
                o.air_fraction
            ));
        }
        let inertia = l.scaled(l.inertia_scale);
        for k in 0..=20 {
            let x = c.stroke_m * k as f64 / 20.0;
            let m = inertia.effective_mass_kg(x);
            if !(m > 0.0 && m.is_finite()) {
                return Err(format!(
                    "[load]: the effective moving mass at x = {x} m is {m} kg (must be > 0)"
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reference_and_perturbed_rigs_are_valid_and_round_trip_through_toml() {
        for rig in [Rig::reference(), Rig::reference().perturbed(21)] {
            rig.validate().unwrap();
            let text = toml::to_string(&rig).unwrap();
            let back: Rig = toml::from_str(&text).unwrap();
            assert_eq!(back, rig, "{text}");
        }
    }

    #[test]
    fn a_file_needs_only_what_it_changes_and_typos_are_errors() {
        let r: Rig = toml::from_str("[valve]\ndead_zone = 0.02\n").unwrap();
        let mut want = Rig::reference();
        want.valve.dead_zone = 0.02;
        assert_eq!(r, want);
        let e = toml::from_str::<Rig>("[valve]\ndead_zome = 0.02\n").unwrap_err();
        assert!(e.to_string().contains("dead_zome"), "{e}");
        assert!(toml::from_str::<Rig>("[plant]\nx = 1\n").is_err());
    }

    #[test]
    fn validation_names_the_field() {
        let mut r = Rig::reference();
        r.cylinder.stroke_m = -0.1;
        assert!(r.validate().unwrap_err().contains("cylinder.stroke_m"));
        let mut r = Rig::reference();
        r.valve.edge_gain[2] = f64::NAN;
        assert!(r.validate().unwrap_err().contains("valve.edge_gain"));
        let mut r = Rig::reference();
        r.fluid.oil.air_fraction = 1.5;
        assert!(r.validate().unwrap_err().contains("air_fraction"));
    }

    #[test]
    fn perturbation_is_seeded_and_bounded() {
        let (a, b) = (Rig::reference().perturbed(7), Rig::reference().perturbed(7));
        assert_eq!(a, b);
        assert_ne!(a, Rig::reference().perturbed(8));
        let r = Rig::reference();
        let ratio = a.valve.flow_gain_extend_lpm_sqrt_bar / r.valve.flow_gain_extend_lpm_sqrt_bar;
        assert!((0.95..=1.05).contains(&ratio));
        assert!(a
            .sensors
            .pressure_offsets_bar
            .iter()
            .all(|o| o.abs() <= 0.3));
        assert!(a.sensors.position_offset_m.abs() <= 0.001);
        assert!((0.005..=0.03).contains(&a.fluid.oil.air_fraction));
    }
}
