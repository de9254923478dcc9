//! Installation parameters: the plant (cylinder, pantograph load, valve,
//! fluid, friction, healthy leakage), the sensors, the filter tuning and the
//! alarm settings.
//!
//! Defaults are the reference thesis rig (ch. 5–6, Table 9-5) with the
//! corrections listed in `../shared/notes/thesis-errata.md`; every choice
//! made where the thesis contradicts itself is documented on the field.
//! Units are in the field names, in the units an engineer reads off a data
//! sheet (bar, l/min, mm are avoided only where SI is the data-sheet unit).
//! On the host, parameters load from TOML (feature `serde`); a file only
//! needs the fields it changes, unknown fields are an error (typo guard).
//! On the device they are compiled in (`Params::nominal()` or a generated
//! constant from `host-sim calibrate`).
//!
//! Every field carries its physical bounds next to it (`in (min ..= max,
//! "unit")`, inclusive, per entry for arrays): wide enough for industrial
//! cylinders and valves (bores ≈ 11–357 mm, strokes 10 mm–6 m, pressures
//! to 1000 bar, valve natural frequencies ≈ 5–800 Hz), narrow enough to
//! refuse nonsense (1e30 kg, 1e300 s, NaN, negative masses). They form the
//! table [`Params::BOUNDS`] with each field's dotted TOML name;
//! [`Params::validate`] (in `validate.rs`) checks it, then the relations
//! between fields and the load model over the stroke. It is the one check
//! of a parameter set: `Monitor::new`, `host-sim replay` and `calibrate`,
//! and the firmware build script all call it.

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

use crate::physics::valve::command_for;

#[macro_use]
mod macros;
mod bounds;
#[cfg(test)]
mod tests;
mod validate;

pub use bounds::{FieldBounds, ParamError, Problem, Range};
pub use validate::{MIN_TIME_CONSTANT_SAMPLES, STROKE_CHECK_POINTS};

params_struct! {
    section "cylinder";
    /// The hydraulic cylinder (LJM NH30 63/30 × 180, thesis appendix D) and
    /// the oil volumes between it and the valve.
    pub struct Cylinder {
        /// Piston (cap) side area A_p, m² (63 mm bore).
        pub piston_area_m2: f64 = 3.117e-3,
            in (1.0e-4 ..= 0.1, "m²"),
        /// Rod side (annulus) area A_r, m² (63 mm bore, 30 mm rod).
        pub rod_side_area_m2: f64 = 2.41e-3,
            in (1.0e-5 ..= 0.1, "m²"),
        /// Stroke, m; position 0 = fully retracted.
        pub stroke_m: f64 = 0.18,
            in (0.01 ..= 6.0, "m"),
        /// Oil volume on the piston side at position 0 (hose, valve port,
        /// manifold), m³. Not given in the thesis: 2 m of 1/2" hose plus
        /// fittings. Calibration fits it together with the bulk modulus.
        pub dead_volume_piston_m3: f64 = 2.0e-4,
            in (1.0e-7 ..= 0.1, "m³"),
        /// Oil volume on the rod side at full extension, m³ (as above).
        pub dead_volume_rod_m3: f64 = 2.0e-4,
            in (1.0e-7 ..= 0.1, "m³"),
    }
}

params_struct! {
    section "load";
    /// The pantograph crane driven by the cylinder (thesis ch. 5). The load
    /// seen by the cylinder, `F = M(x)·ẍ + ½M'(x)·ẋ² + G(x)`, is derived
    /// from this geometry by the Lagrangian of §5.2 (see `load.rs`): the
    /// thesis' eq. 5.57 with a constant c3·x gravity term is not used
    /// (erratum 6).
    pub struct Pantograph {
        /// Angle of rods 1 and 3 vs. piston position, degrees (fit eq. 5.4):
        /// θ1 = a·x + b, `[a (°/m), b (°)]`.
        pub theta1_fit_deg: [f64; 2] = [162.5, -19.99],
            in [(-1.0e5 ..= 1.0e5, "°/m"), (-360.0 ..= 360.0, "°")],
        /// Angle of rods 2.1 and 2.2, degrees (fit eq. 5.5):
        /// θ2 = a·x² + b·x + c, `[a (°/m²), b (°/m), c (°)]`.
        pub theta2_fit_deg: [f64; 3] = [-664.6, 163.9, 87.71],
            in [(-1.0e7 ..= 1.0e7, "°/m²"), (-1.0e5 ..= 1.0e5, "°/m"), (-360.0 ..= 360.0, "°")],
        /// Height of the rod 2.1 pivot above the base frame, m.
        pub base_to_r21_y_m: f64 = 0.155,
            in (-20.0 ..= 20.0, "m"),
        /// Rod 2.1 pivot → rod 1 pivot, along rod 2.1, m.
        pub r21_to_r1_m: f64 = 0.125,
            in (0.0 ..= 20.0, "m"),
        /// Rod 2.1 pivot → rod 3 pivot, along rod 2.1, m.
        pub r21_to_r3_m: f64 = 1.0,
            in (0.0 ..= 20.0, "m"),
        /// Rod 2.1 pivot → its centre of mass, m.
        pub r21_to_cg21_m: f64 = 0.508,
            in (0.0 ..= 20.0, "m"),
        /// Rod 1 pivot → its centre of mass, m.
        pub r1_to_cg1_m: f64 = 0.186,
            in (0.0 ..= 20.0, "m"),
        /// Rod 1 pivot → rod 2.2 pivot, along rod 1, m.
        pub r1_to_r22_m: f64 = 0.365,
            in (0.0 ..= 20.0, "m"),
        /// Rod 2.2 pivot → its centre of mass, m.
        pub r22_to_cg22_m: f64 = 0.44,
            in (0.0 ..= 20.0, "m"),
        /// Rod 3 pivot → its centre of mass, m.
        pub r3_to_cg3_m: f64 = 1.35,
            in (0.0 ..= 20.0, "m"),
        /// Masses of rods 1, 2.1, 2.2 and 3, kg.
        pub masses_kg: [f64; 4] = [6.12844, 15.36792, 13.62235, 87.92456],
            in (0.0 ..= 50_000.0, "kg"),
        /// Moments of inertia of rods 1, 2.1, 2.2, 3 about their centres of
        /// mass, kg·m². The thesis gives none; these treat each rod as a
        /// slender bar twice as long as its pivot-to-centre distance
        /// (m·L²/12). They contribute ~25 % of the effective mass.
        pub inertias_kg_m2: [f64; 4] = [0.070_673, 1.321_969, 0.879_096, 53.414_170],
            in (0.0 ..= 1.0e7, "kg·m²"),
        /// Gravitational acceleration, m/s² (the thesis' "kg/m²" is a typo).
        pub gravity_m_s2: f64 = 9.81,
            in (0.0 ..= 10.0, "m/s²"),
        /// Multiplies the gravity load: unaccounted masses (paint, welds,
        /// bolts, payload; §7.1 found ≈ 50 N missing). Fitted by calibration.
        pub gravity_scale: f64 = 1.0,
            in (0.05 ..= 20.0, ""),
        /// Multiplies the effective moving mass. Fitted by calibration.
        pub inertia_scale: f64 = 1.0,
            in (0.05 ..= 20.0, ""),
        /// Constant force added to the load, N (positive opposes extension).
        pub force_offset_n: f64 = 0.0,
            in (-5.0e6 ..= 5.0e6, "N"),
    }
}

params_struct! {
    section "valve";
    /// The servo directional control valve (Moog D633 class, thesis §6.3.1
    /// and §6.4).
    pub struct Valve {
        /// Spool natural frequency ω_v, rad/s (280π).
        pub natural_frequency_rad_s: f64 = 879.645_943,
            in (30.0 ..= 5000.0, "rad/s"),
        /// Spool damping ratio ζ_v.
        pub damping_ratio: f64 = 0.92,
            in (0.05 ..= 5.0, ""),
        /// Flow gain for positive spool travel (P→A and B→T), l/min per
        /// √bar at full opening: Q = K·opening·√Δp. Thesis K_v1 = 4.165e-7
        /// m³/(s·√Pa) = 7.9025 l/min/√bar.
        pub flow_gain_extend_lpm_sqrt_bar: f64 = 7.9025,
            in (0.01 ..= 1000.0, "l/min/√bar"),
        /// Flow gain for negative spool travel (P→B and A→T), l/min/√bar.
        /// Thesis K_v2 = 3.91e-7 m³/(s·√Pa).
        pub flow_gain_retract_lpm_sqrt_bar: f64 = 7.4187,
            in (0.01 ..= 1000.0, "l/min/√bar"),
        /// Spool overlap (dead zone) as a fraction of full travel: the
        /// metering edges open at |x_v| > dead_zone, and the opening grows
        /// from zero there (the thesis' discontinuous form, erratum 5, is not
        /// used). §6.3.1.1 measured ≈ 0.015.
        pub dead_zone: f64 = 0.015,
            in (0.0 ..= 0.45, ""),
        /// Spool position at zero command (null bias), fraction of travel.
        pub null_offset: f64 = 0.0,
            in (-0.5 ..= 0.5, ""),
        /// Flow gain of the B→T edge relative to the P→A edge (both open for
        /// positive travel). Fitted by calibration.
        pub rod_edge_gain_extend: f64 = 1.0,
            in (0.2 ..= 5.0, ""),
        /// Flow gain of the P→B edge relative to the A→T edge.
        pub rod_edge_gain_retract: f64 = 1.0,
            in (0.2 ..= 5.0, ""),
        /// How much later the B→T edge opens than the P→A edge, fraction of
        /// travel (negative: earlier). A valve whose edges differ in overlap,
        /// or pass laminar land leakage beside the opening, meters a
        /// different share through each side at small and large openings;
        /// one gain ratio fits only the openings calibration saw. Fitted by
        /// calibration.
        pub rod_edge_offset_extend: f64 = 0.0,
            in (-0.05 ..= 0.05, ""),
        /// How much later the P→B edge opens than the A→T edge, fraction of
        /// travel (negative: earlier).
        pub rod_edge_offset_retract: f64 = 0.0,
            in (-0.05 ..= 0.05, ""),
        /// Laminar leakage across each of the four covered metering edges
        /// (P→A, A→T, P→B, B→T), l/min per bar. The thesis' per-edge values
        /// of §6.3.1.2 give litres per minute at rest (erratum 2); its
        /// nomenclature value 5.5e-13 m³/(s·Pa) = 3.3e-3 l/min/bar gives
        /// ≈ 0.15 l/min at 50 bar, the order of a D633's null leakage.
        pub edge_leak_lpm_per_bar: f64 = 3.3e-3,
            in (0.0 ..= 1.0, "l/min/bar"),
        /// Pressure drop below which orifice flow turns laminar, bar. Keeps
        /// the flow law differentiable at Δp = 0.
        pub laminar_dp_bar: f64 = 1.0,
            in (1.0e-3 ..= 50.0, "bar"),
        /// Asymmetry of chamber A's two covered edges: with the spool
        /// centred P→A leaks `edge_leak_lpm_per_bar`·(1 + s), A→T ·(1 − s),
        /// so the chamber's leak-only equilibrium sits s·(p_S − p_T)/2
        /// above mid-pressure. Fitted by calibration from the holds; 0:
        /// symmetric edges.
        pub edge_leak_skew_a: f64 = 0.0,
            in (-0.95 ..= 0.95, ""),
        /// As above for chamber B: P→B ·(1 + s), B→T ·(1 − s).
        pub edge_leak_skew_b: f64 = 0.0,
            in (-0.95 ..= 0.95, ""),
        /// How fast a covered edge's land leakage grows as spool travel
        /// uncovers it, e-folds per unit of travel (1/λ): P→A and B→T leak
        /// ·e^(g·x_v), A→T and P→B ·e^(−g·x_v), x_v held to ±`dead_zone`
        /// (g·`dead_zone` ≤ 8). A servo valve's pressure gain at null: a
        /// few hundredths of travel is one e-fold (g = 50–200). Fitted by
        /// calibration from the holds; 0: no growth.
        pub edge_leak_spool_gain: f64 = 0.0,
            in (0.0 ..= 200.0, ""),
        /// The covered edges' land leakage at a hold (spool inside the
        /// dead zone), × `edge_leak_lpm_per_bar`, held there: the filters'
        /// laminar state then scales the land leakage only while the
        /// valve meters and cannot take in a leak the holding loop feeds
        /// through those edges. Blended into the metering valve's over
        /// `physics::valve::HOLD_BLEND_TRAVEL` of travel past the
        /// dead zone. 0: the laminar state scales the land leakage
        /// everywhere (as where the oil temperature holds it). Calibration
        /// sets it where no temperature is read.
        pub hold_edge_leak_scale: f64 = 0.0,
            in (0.0 ..= 20.0, ""),
    }
}

params_struct! {
    section "fluid";
    /// The hydraulic oil.
    pub struct Fluid {
        /// Bulk modulus of air-free oil, including hose compliance, bar.
        pub bulk_modulus_bar: f64 = 16_000.0,
            in (500.0 ..= 30_000.0, "bar"),
        /// Entrained air fraction at atmospheric pressure (eq. 6.9, 0–0.15).
        pub air_fraction: f64 = 0.01,
            in (0.0 ..= 0.2, ""),
        /// Adiabatic index of the entrained air.
        pub adiabatic_index: f64 = 1.4,
            in (1.0 ..= 1.7, ""),
        /// Atmospheric pressure, bar (absolute).
        pub atmospheric_pressure_bar: f64 = 1.013,
            in (0.5 ..= 1.1, "bar"),
        /// Oil temperature the leakage coefficients refer to, °C.
        pub reference_temperature_c: f64 = 25.0,
            in (-40.0 ..= 120.0, "°C"),
        /// Viscosity–temperature slope k in ν(T) = ν_ref·exp(−k·(T − T_ref)),
        /// 1/°C. ISO VG 46 mineral oil: ν halves from 25 °C to 40 °C.
        pub viscosity_temperature_coeff_per_c: f64 = 0.045,
            in (0.0 ..= 0.2, "1/°C"),
    }
}

params_struct! {
    section "friction";
    /// Cylinder and crane friction, eq. 6.17 with the sign fixed (erratum 3):
    /// F_f = (F_c + (F_brk − F_c)·e^(−c_v·|v|))·sign(v) + B·v.
    pub struct Friction {
        /// Coulomb friction F_c, N (§7.1 measured ≈ 480 N).
        pub coulomb_n: f64 = 480.0,
            in (0.0 ..= 5.0e5, "N"),
        /// Breakaway (static) friction F_brk, N (the thesis table's 990 N).
        pub breakaway_n: f64 = 990.0,
            in (0.0 ..= 5.0e5, "N"),
        /// Stribeck decay constant c_v, s/m.
        pub stribeck_s_per_m: f64 = 10.0,
            in (0.0 ..= 1.0e4, "s/m"),
        /// Viscous friction B, N·s/m (the thesis' "N·m·s" is a typo).
        pub viscous_ns_per_m: f64 = 5000.0,
            in (0.0 ..= 1.0e7, "N·s/m"),
        /// Velocity scale of the model's smooth sign(v) = v/√(v² + v_s²),
        /// m/s. Stands in for stiction: under a net force below breakaway
        /// the model creeps at up to ≈ v_s. Creep displaces oil exactly as
        /// an internal leak does (piston side loses, rod side gains: at
        /// 0.5 mm/s that is 0.09 l/min), so v_s must be small; the implicit
        /// velocity update keeps the resulting stiffness stable.
        pub smoothing_m_s: f64 = 2.0e-5,
            in (1.0e-7 ..= 0.01, "m/s"),
    }
}

params_struct! {
    section "leakage";
    /// Leakage present in a healthy installation, at the reference
    /// temperature. Leaks reported by the monitor are flows above these.
    pub struct Leakage {
        /// Piston seal leakage, piston chamber → rod chamber, l/min per bar.
        /// §6.3.3 gives K_Lp = 1e-12 m³/(s·Pa) = 6e-3 l/min/bar; the
        /// nomenclature's 2.32e-9 would be > 100 l/min (erratum 1).
        pub seal_lpm_per_bar: f64 = 6.0e-3,
            in (0.0 ..= 0.1, "l/min/bar"),
        /// Baseline leakage from the rod side to tank, l/min per bar (e.g.
        /// a valve that leaks a little more on one side). Set by
        /// calibration so that a healthy installation reads zero; may be
        /// slightly negative as a correction of the valve's edge leakage.
        pub external_lpm_per_bar: f64 = 0.0,
            in (-0.009 ..= 0.5, "l/min/bar"),
    }
}

params_struct! {
    section "baseline";
    /// The healthy installation's repeatable model error, learned by
    /// calibration per operating region: what the `both` filter's leak
    /// coefficients read on the leak-free installation. The decision layer
    /// subtracts it before it compares a leak with the thresholds. Regions
    /// by the valve command u: retracting (u < null − dead zone), holding
    /// (|u − null| ≤ dead zone), extending (u > null + dead zone).
    pub struct Baseline {
        /// Apparent internal leak coefficient per region `[retracting,
        /// holding, extending]`, l/min at 10 bar across the piston.
        pub internal_lpm_per_10bar: [f64; 3] = [0.0; 3],
            in (-0.999 ..= 0.999, "l/min at 10 bar"),
        /// Apparent external leak coefficient per region, l/min at 10 bar
        /// from the rod side to tank.
        pub external_lpm_per_10bar: [f64; 3] = [0.0; 3],
            in (-0.999 ..= 0.999, "l/min at 10 bar"),
        /// The installation's detection floor per leak `[internal,
        /// external]`, l/min: how far the leak readings of the leak-free
        /// installation still wander (model error the baseline cannot
        /// remove), measured by calibration on a part of its recording it
        /// did not fit. A leak alarms only above the larger of this and
        /// `alarm.alarm_lpm` — the smallest leak this installation can be
        /// trusted to tell. 0: no floor.
        pub detection_floor_lpm: [f64; 2] = [0.0; 2],
            in (0.0 ..= 10.0, "l/min"),
        /// The internal leak's detection floor per region `[retracting,
        /// holding, extending]`, l/min, where it is higher than
        /// `detection_floor_lpm`: the model error of a valve differs with
        /// the direction of flow (metering during moves, land leakage at
        /// holds), so the floor is set where the error is, not
        /// everywhere. 0: `detection_floor_lpm` applies.
        pub region_floor_internal_lpm: [f64; 3] = [0.0; 3],
            in (0.0 ..= 10.0, "l/min"),
        /// The same for the external leak, l/min.
        pub region_floor_external_lpm: [f64; 3] = [0.0; 3],
            in (0.0 ..= 10.0, "l/min"),
        /// A provisional set's gross leak level, l/min. A set that was not
        /// calibrated for this installation (the compiled-in reference
        /// rig's on a new machine, or the fallback after calibration
        /// refused) cannot back a `healthy` claim: the model error of an
        /// unknown installation reads as leaks of up to about this size.
        /// Above 0 the verdict is never `healthy` (`inconclusive`, flag
        /// `provisional`) and a leak alarms only above this level, so that
        /// a gross leak is still caught. 0: the set describes this
        /// installation (`calibrate` writes 0).
        pub provisional_floor_lpm: f64 = 0.0,
            in (0.0 ..= 10.0, "l/min"),
        /// The valve command (normalised, −1 … 1) with which the leak-free
        /// installation's loop holds the piston: `calibrate` writes the
        /// median over its recording's quiet holds (after 5 s, evidence
        /// weight ≥ 0.5, at least 0.2 s of them).
        pub hold_command: f64 = 0.0,
            in (-1.0 ..= 1.0, ""),
        /// How far the average holding command may stand from
        /// `hold_command` (normalised) before the monitor no longer claims
        /// `healthy` (`health::HOLD_COMMAND_SHIFTED`): at a hold the loop
        /// must feed any leak through the valve, whatever the filters make
        /// of that flow. 0: not followed (the default; `calibrate` writes
        /// 0.003 where its recording's quiet holds agree on one command).
        /// A valve's null moves with oil temperature and supply pressure:
        /// an installation run far from where it was calibrated reads
        /// `inconclusive` more, never a leak.
        pub hold_command_tolerance: f64 = 0.0,
            in (0.0 ..= 0.5, ""),
    }
}

params_struct! {
    section "sensors";
    /// The measurement chain.
    pub struct Sensors {
        /// White noise on each pressure reading, bar (1σ).
        pub pressure_noise_bar: f64 = 0.08,
            in (1.0e-5 ..= 20.0, "bar"),
        /// White noise on the position reading, m (1σ).
        pub position_noise_m: f64 = 5.0e-5,
            in (1.0e-9 ..= 0.01, "m"),
        /// First-order lag of the pressure transmitters, s (MBS 3050: < 4 ms).
        pub pressure_lag_s: f64 = 0.004,
            in (0.0 ..= 0.05, "s"),
        /// Offsets subtracted from the supply, piston, rod and tank
        /// pressure readings, bar. Fitted by calibration.
        pub pressure_offsets_bar: [f64; 4] = [0.0, 0.0, 0.0, 0.0],
            in (-20.0 ..= 20.0, "bar"),
        /// Offset subtracted from the position reading, m.
        pub position_offset_m: f64 = 0.0,
            in (-10.0 ..= 10.0, "m"),
        /// Plausible pressure range, bar: readings outside are sensor faults.
        /// The lower limit is the lowest reading a 400 bar NAMUR NE43
        /// transmitter still gives as a measurement (3.8 mA): a tank
        /// reading's noise about 0 bar reaches there on a valid signal
        /// (−2 bar faulted noisy tank transmitters of uncalibrated survey
        /// rigs); a broken loop (≤ 3.6 mA) reads −6 bar or lower.
        pub pressure_range_bar: [f64; 2] = [-5.0, 400.0],
            in [(-200.0 ..= 0.0, "bar"), (10.0 ..= 1000.0, "bar")],
        /// Plausible position range beyond the stroke ends, m.
        pub position_margin_m: f64 = 0.01,
            in (0.0 ..= 1.0, "m"),
        /// Lowest white-noise σ the filters assume for a pressure reading,
        /// bar, whatever the online estimate says (a quantised, noise-free
        /// recording has none at holds).
        pub pressure_noise_floor_bar: f64 = 0.01,
            in (1.0e-5 ..= 5.0, "bar"),
        /// Lowest white-noise σ assumed for the position reading, m.
        pub position_noise_floor_m: f64 = 2.0e-6,
            in (1.0e-9 ..= 1.0e-3, "m"),
    }
}

params_struct! {
    section "filter";
    /// EKF tuning, in the filter's scaled units (the reference scales
    /// `X_REF`, `P_REF`, `GAIN_REF`, `LAMINAR_REF` in `model`): process-noise
    /// intensities are per second.
    pub struct FilterTuning {
        /// Integration substeps per sample for the state prediction.
        pub substeps: u32 = 2,
            in (1.0 ..= 16.0, ""),
        /// Process noise on piston position, (scaled unit)²/s.
        pub q_position: f64 = 1.0e-8,
            in (0.0 ..= 1.0, "scaled²/s"),
        /// Process noise on piston velocity (unmodelled forces).
        pub q_velocity: f64 = 4.0e-4,
            in (0.0 ..= 1.0, "scaled²/s"),
        /// Process noise on spool position (valve model error).
        pub q_spool: f64 = 1.0e-6,
            in (0.0 ..= 1.0, "scaled²/s"),
        /// Process noise on spool velocity.
        pub q_spool_rate: f64 = 1.0e-6,
            in (0.0 ..= 1.0, "scaled²/s"),
        /// Process noise on chamber pressures (flow model error).
        pub q_pressure: f64 = 4.0e-5,
            in (0.0 ..= 1.0, "scaled²/s"),
        /// Random-walk intensity of each valve flow-gain deviation
        /// (relative)²/s: slow, valves drift with wear, not within seconds.
        pub q_gain: f64 = 1.0e-7,
            in (0.0 ..= 0.01, "1/s"),
        /// Prior 1σ of each valve flow-gain deviation (relative).
        pub gain_prior: f64 = 0.08,
            in (0.0 ..= 1.0, ""),
        /// Random-walk intensity of the healthy laminar-leakage deviation
        /// (relative)²/s: oil warms over minutes (≈ 2 %/√s). 0 holds the
        /// factor (calibration does so where the oil temperature is read):
        /// the temperature is then a required reading.
        pub q_laminar: f64 = 4.0e-4,
            in (0.0 ..= 1.0, "1/s"),
        /// Prior 1σ of the laminar-leakage deviation (relative): 25 → 40 °C
        /// without a temperature reading is +100 %.
        pub laminar_prior: f64 = 0.5,
            in (0.0 ..= 5.0, ""),
        /// Lowest healthy laminar leakage the filters may estimate, as a
        /// fraction of what the temperature gives (1: as the viscosity
        /// says). Leakage never runs backwards, and a factor far below 1
        /// is the filter making up for model error with the term that is
        /// collinear with an internal leak. Below 0 the term is a free
        /// nuisance that may run backwards: calibration's fallback (−5)
        /// for an installation the bound cannot describe.
        pub laminar_factor_min: f64 = 0.1,
            in (-5.0 ..= 1.0, ""),
        /// Random-walk intensity of each leak coefficient, (l/min at 10 bar)²/s.
        pub q_leak: f64 = 5.0e-3,
            in (0.0 ..= 10.0, "(l/min at 10 bar)²/s"),
        /// Prior 1σ of each leak coefficient, l/min at 10 bar.
        pub leak_prior_lpm: f64 = 0.1,
            in (1.0e-4 ..= 10.0, "l/min at 10 bar"),
        /// Time constant of the evidence memory and of the reported leak
        /// size average, s.
        pub evidence_window_s: f64 = 4.0,
            in (0.01 ..= 600.0, "s"),
        /// Time constant of the leak-flow average used for detection, s.
        pub detection_window_s: f64 = 0.25,
            in (0.005 ..= 60.0, "s"),
        /// Residual correlation length, samples: log-likelihoods are divided
        /// by it (consecutive model residuals are not independent).
        pub residual_correlation_samples: f64 = 50.0,
            in (1.0 ..= 10_000.0, "samples"),
        /// Log-likelihood charged per leak state and second of evidence
        /// (nested hypotheses: a free leak always fits a little better).
        pub complexity_penalty_per_s: f64 = 2.0,
            in (1.0e-3 ..= 100.0, "1/s"),
        /// After a (re)start no alarm is raised for this long while the
        /// filters converge, s. The leak states learn during it, and the
        /// alarm's lower 2σ bound keeps an estimate the filter is still
        /// unsure of from alarming after it. A 10 s valve step test (step
        /// at 3 s) has its hold before the step as its only good evidence
        /// (against the end stop nothing shows a leak): 0.5 s instead of
        /// 2 s detected 3 / 1 / 5 more step-test leaks and made 0 / 1 / 3
        /// more healthy step tests conclusive on the development / further
        /// / survey rigs, with no false alarm.
        pub warm_up_s: f64 = 0.5,
            in (0.0 ..= 600.0, "s"),
        /// Estimated chamber-pressure rate at which a sample counts half as
        /// evidence and the valve and leak parameters learn at half weight,
        /// bar/s (see `quiet.rs`; 0 disables the weighting).
        pub quiet_rate_bar_s: f64 = 10.0,
            in (0.0 ..= 1.0e4, "bar/s"),
        /// Valve metering flow at which a sample counts half as evidence and
        /// the leak states learn at half weight, l/min.
        pub quiet_flow_lpm: f64 = 10.0,
            in (0.01 ..= 1.0e4, "l/min"),
        /// Valve metering flow at which the valve flow-gain states learn at
        /// half weight, l/min (they are not observable at holds).
        pub gain_learning_flow_lpm: f64 = 2.0,
            in (0.01 ..= 1.0e4, "l/min"),
        /// Time constant with which learning resumes after a transient, s.
        pub learning_recovery_s: f64 = 0.3,
            in (0.0 ..= 60.0, "s"),
        /// Nominal sample period, s; gaps over 5 periods re-initialise.
        pub sample_period_s: f64 = 0.001,
            in (1.0e-4 ..= 0.01, "s"),
        /// Time constant of the online estimate of each reading's noise, s
        /// (`signal::noise`); `sensors.*_noise_*` are its starting values.
        pub noise_time_constant_s: f64 = 2.0,
            in (0.01 ..= 600.0, "s"),
        /// Evidence-weighted time the filters must have seen after the
        /// warm-up before the monitor claims `healthy`, s.
        pub min_evidence_s: f64 = 0.5,
            in (0.0 ..= 600.0, "s"),
        /// Time constant of the recent evidence weight, s: when its average
        /// falls below `min_evidence_fraction` the verdict is
        /// `inconclusive` (too little quasi-steady operation for too long).
        pub evidence_memory_s: f64 = 30.0,
            in (0.1 ..= 3600.0, "s"),
        /// See `evidence_memory_s`.
        pub min_evidence_fraction: f64 = 0.05,
            in (0.0 ..= 0.9, ""),
    }
}

params_struct! {
    section "alarm";
    /// When to warn and alarm.
    pub struct AlarmConfig {
        /// Leak flow that raises a warning, l/min (on the reported average).
        pub warning_lpm: f64 = 0.05,
            in (1.0e-3 ..= 100.0, "l/min"),
        /// Leak flow that raises the alarm, l/min. The default sits below
        /// 0.1 l/min so that leaks of 0.1 l/min are caught, and above the
        /// largest healthy reading seen in evaluation (≈ 0.07 l/min).
        pub alarm_lpm: f64 = 0.08,
            in (1.0e-3 ..= 100.0, "l/min"),
        /// CUSUM decision interval, s: an alarm is raised when the time
        /// integral of the relative excess over the alarm level reaches it
        /// (this long at twice the alarm level).
        pub debounce_s: f64 = 0.5,
            in (0.0 ..= 60.0, "s"),
        /// Minimum posterior probability of the leak hypothesis.
        pub min_probability: f64 = 0.9,
            in (0.5 ..= 0.9999, ""),
    }
}

params_struct! {
    section "can";
    /// The monitor on the CAN bus.
    pub struct CanConfig {
        /// Node number on a bus shared by several monitors: moves the whole
        /// identifier block by 0x20 per node (`protocol::Node`); 0 keeps
        /// the identifiers of the DBC.
        pub node: u32 = 0,
            in (0.0 ..= 7.0, ""),
    }
}

/// The gross leak level of [`Params::PROVISIONAL`], l/min: the largest
/// leak reading of the development rigs' leak-free runs with the reference
/// rig's values uncalibrated (2.9 l/min, `host-sim eval --set dev
/// --no-calibration`) times the calibration's floor margin of 1.5, rounded
/// up (see `docs/calibration.md`, "Without a calibration").
pub const PROVISIONAL_FLOOR_LPM: f64 = 5.0;

/// Everything the monitor needs to know about one installation.
#[derive(Clone, Debug, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct Params {
    /// Cylinder geometry and dead volumes.
    pub cylinder: Cylinder,
    /// The crane the cylinder moves.
    pub load: Pantograph,
    /// The servo valve.
    pub valve: Valve,
    /// The oil.
    pub fluid: Fluid,
    /// Friction.
    pub friction: Friction,
    /// Healthy leakage.
    pub leakage: Leakage,
    /// The healthy installation's apparent leaks per operating region.
    pub baseline: Baseline,
    /// Sensors.
    pub sensors: Sensors,
    /// Filter tuning.
    pub filter: FilterTuning,
    /// Alarm thresholds.
    pub alarm: AlarmConfig,
    /// The CAN bus.
    pub can: CanConfig,
}

/// The retracting region's index in [`operating_region`]'s numbering.
pub const RETRACTING_REGION: usize = 0;
/// The holding region's index in [`operating_region`]'s numbering.
pub const HOLDING_REGION: usize = 1;
/// The extending region's index in [`operating_region`]'s numbering.
pub const EXTENDING_REGION: usize = 2;

/// Operating region of a valve command for `[baseline]`:
/// [`RETRACTING_REGION`] (u < null − dead zone), [`HOLDING_REGION`],
/// [`EXTENDING_REGION`] (u > null + dead zone). `hold_band` is
/// [`Params::hold_band`].
pub fn operating_region(u: f32, hold_band: (f32, f32)) -> usize {
    if u < hold_band.0 {
        RETRACTING_REGION
    } else if u > hold_band.1 {
        EXTENDING_REGION
    } else {
        HOLDING_REGION
    }
}

impl Params {
    /// The node number on the CAN bus (validated: 0..=7; an unvalidated
    /// set out of range gives node 0).
    pub fn node(&self) -> crate::protocol::Node {
        crate::protocol::Node::new(self.can.node).unwrap_or_default()
    }

    /// The valve commands of the holding region, those that put the spool
    /// (command + `null_offset`) inside the dead zone: −null ± dead zone.
    pub fn hold_band(&self) -> (f32, f32) {
        let v = &self.valve;
        (
            command_for(-v.dead_zone, v.null_offset) as f32,
            command_for(v.dead_zone, v.null_offset) as f32,
        )
    }

    /// The healthy laminar-leakage factor is held (no random walk,
    /// `filter.q_laminar` 0): the viscosity then follows the oil
    /// temperature alone, which becomes a required reading.
    pub fn laminar_factor_held(&self) -> bool {
        self.filter.q_laminar == 0.0
    }

    /// The reference thesis rig (ch. 5–6).
    pub const NOMINAL: Params = Params {
        cylinder: Cylinder::NOMINAL,
        load: Pantograph::NOMINAL,
        valve: Valve::NOMINAL,
        fluid: Fluid::NOMINAL,
        friction: Friction::NOMINAL,
        leakage: Leakage::NOMINAL,
        baseline: Baseline::NOMINAL,
        sensors: Sensors::NOMINAL,
        filter: FilterTuning::NOMINAL,
        alarm: AlarmConfig::NOMINAL,
        can: CanConfig::NOMINAL,
    };

    /// The reference thesis rig (ch. 5–6).
    pub fn nominal() -> Self {
        Self::NOMINAL
    }

    /// The reference rig's values as a provisional set for an installation
    /// that has not been calibrated (see
    /// [`Baseline::provisional_floor_lpm`]): what the firmware runs when
    /// no installation set was compiled in or stored, and `host-sim
    /// replay` without `--params`.
    pub const PROVISIONAL: Params = Params {
        baseline: Baseline {
            provisional_floor_lpm: PROVISIONAL_FLOOR_LPM,
            ..Baseline::NOMINAL
        },
        ..Self::NOMINAL
    };

    /// [`Self::PROVISIONAL`].
    pub fn provisional() -> Self {
        Self::PROVISIONAL
    }

    /// This set as a provisional one (its gross level at least
    /// [`PROVISIONAL_FLOOR_LPM`]): for an installation it was not
    /// calibrated for.
    pub fn into_provisional(mut self) -> Self {
        let b = &mut self.baseline;
        b.provisional_floor_lpm = b.provisional_floor_lpm.max(PROVISIONAL_FLOOR_LPM);
        self
    }

    /// Whether this set was not calibrated for its installation.
    pub fn is_provisional(&self) -> bool {
        self.baseline.provisional_floor_lpm > 0.0
    }

    /// The bounds table: every section's fields with their physical
    /// bounds, section by section as in the TOML file.
    pub const BOUNDS: [&'static [FieldBounds]; 11] = [
        Cylinder::BOUNDS,
        Pantograph::BOUNDS,
        Valve::BOUNDS,
        Fluid::BOUNDS,
        Friction::BOUNDS,
        Leakage::BOUNDS,
        Baseline::BOUNDS,
        Sensors::BOUNDS,
        FilterTuning::BOUNDS,
        AlarmConfig::BOUNDS,
        CanConfig::BOUNDS,
    ];

    /// Every field's bounds (see [`Params::BOUNDS`]).
    pub fn bounds() -> impl Iterator<Item = &'static FieldBounds> {
        Self::BOUNDS.iter().flat_map(|s| s.iter())
    }

    /// The bounds of the field with dotted name `field`, if there is one.
    pub fn bounds_of(field: &str) -> Option<&'static FieldBounds> {
        Self::bounds().find(|b| b.field == field)
    }
}
