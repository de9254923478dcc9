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

#[cfg(feature = "serde")]
use serde::{Deserialize, Serialize};

macro_rules! params_struct {
    ($(#[$m:meta])* pub struct $name:ident { $($(#[$fm:meta])* pub $field:ident : $ty:ty = $default:expr,)* }) => {
        $(#[$m])*
        #[derive(Clone, Debug, PartialEq)]
        #[cfg_attr(feature = "serde", derive(Serialize, Deserialize))]
        #[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
        pub struct $name { $($(#[$fm])* pub $field: $ty,)* }
        impl $name {
            /// The reference thesis rig's values.
            pub const NOMINAL: Self = Self { $($field: $default,)* };
        }
        impl Default for $name {
            fn default() -> Self { Self::NOMINAL }
        }
    };
}

params_struct! {
    /// The hydraulic cylinder (LJM NH30 63/30 × 180, thesis appendix D) and
    /// the oil volumes between it and the valve.
    pub struct Cylinder {
        /// Piston (cap) side area A_p, m² (63 mm bore).
        pub piston_area_m2: f64 = 3.117e-3,
        /// Rod side (annulus) area A_r, m² (63 mm bore, 30 mm rod).
        pub rod_side_area_m2: f64 = 2.41e-3,
        /// Stroke, m; position 0 = fully retracted.
        pub stroke_m: f64 = 0.18,
        /// Oil volume on the piston side at position 0 (hose, valve port,
        /// manifold), m³. Not given in the thesis: 2 m of 1/2" hose plus
        /// fittings. Calibration fits it together with the bulk modulus.
        pub dead_volume_piston_m3: f64 = 2.0e-4,
        /// Oil volume on the rod side at full extension, m³ (as above).
        pub dead_volume_rod_m3: f64 = 2.0e-4,
    }
}

params_struct! {
    /// The pantograph crane driven by the cylinder (thesis ch. 5). The load
    /// seen by the cylinder, `F = M(x)·ẍ + ½M'(x)·ẋ² + G(x)`, is derived
    /// from this geometry by the Lagrangian of §5.2 (see `load.rs`): the
    /// thesis' eq. 5.57 with a constant c3·x gravity term is not used
    /// (erratum 6).
    pub struct Pantograph {
        /// Angle of rods 1 and 3 vs. piston position, degrees (fit eq. 5.4):
        /// θ1 = a·x + b, `[a (°/m), b (°)]`.
        pub theta1_fit_deg: [f64; 2] = [162.5, -19.99],
        /// Angle of rods 2.1 and 2.2, degrees (fit eq. 5.5):
        /// θ2 = a·x² + b·x + c, `[a (°/m²), b (°/m), c (°)]`.
        pub theta2_fit_deg: [f64; 3] = [-664.6, 163.9, 87.71],
        /// Height of the rod 2.1 pivot above the base frame, m.
        pub base_to_r21_y_m: f64 = 0.155,
        /// Rod 2.1 pivot → rod 1 pivot, along rod 2.1, m.
        pub r21_to_r1_m: f64 = 0.125,
        /// Rod 2.1 pivot → rod 3 pivot, along rod 2.1, m.
        pub r21_to_r3_m: f64 = 1.0,
        /// Rod 2.1 pivot → its centre of mass, m.
        pub r21_to_cg21_m: f64 = 0.508,
        /// Rod 1 pivot → its centre of mass, m.
        pub r1_to_cg1_m: f64 = 0.186,
        /// Rod 1 pivot → rod 2.2 pivot, along rod 1, m.
        pub r1_to_r22_m: f64 = 0.365,
        /// Rod 2.2 pivot → its centre of mass, m.
        pub r22_to_cg22_m: f64 = 0.44,
        /// Rod 3 pivot → its centre of mass, m.
        pub r3_to_cg3_m: f64 = 1.35,
        /// Masses of rods 1, 2.1, 2.2 and 3, kg.
        pub masses_kg: [f64; 4] = [6.12844, 15.36792, 13.62235, 87.92456],
        /// Moments of inertia of rods 1, 2.1, 2.2, 3 about their centres of
        /// mass, kg·m². The thesis gives none; these treat each rod as a
        /// slender bar twice as long as its pivot-to-centre distance
        /// (m·L²/12). They contribute ~25 % of the effective mass.
        pub inertias_kg_m2: [f64; 4] = [0.070_673, 1.321_969, 0.879_096, 53.414_170],
        /// Gravitational acceleration, m/s² (the thesis' "kg/m²" is a typo).
        pub gravity_m_s2: f64 = 9.81,
        /// Multiplies the gravity load: unaccounted masses (paint, welds,
        /// bolts, payload; §7.1 found ≈ 50 N missing). Fitted by calibration.
        pub gravity_scale: f64 = 1.0,
        /// Multiplies the effective moving mass. Fitted by calibration.
        pub inertia_scale: f64 = 1.0,
        /// Constant force added to the load, N (positive opposes extension).
        pub force_offset_n: f64 = 0.0,
    }
}

params_struct! {
    /// The servo directional control valve (Moog D633 class, thesis §6.3.1
    /// and §6.4).
    pub struct Valve {
        /// Spool natural frequency ω_v, rad/s (280π).
        pub natural_frequency_rad_s: f64 = 879.645_943,
        /// Spool damping ratio ζ_v.
        pub damping_ratio: f64 = 0.92,
        /// Flow gain for positive spool travel (P→A and B→T), l/min per
        /// √bar at full opening: Q = K·opening·√Δp. Thesis K_v1 = 4.165e-7
        /// m³/(s·√Pa) = 7.9025 l/min/√bar.
        pub flow_gain_extend_lpm_sqrt_bar: f64 = 7.9025,
        /// Flow gain for negative spool travel (P→B and A→T), l/min/√bar.
        /// Thesis K_v2 = 3.91e-7 m³/(s·√Pa).
        pub flow_gain_retract_lpm_sqrt_bar: f64 = 7.4187,
        /// Spool overlap (dead zone) as a fraction of full travel: the
        /// metering edges open at |x_v| > dead_zone, and the opening grows
        /// from zero there (the thesis' discontinuous form, erratum 5, is not
        /// used). §6.3.1.1 measured ≈ 0.015.
        pub dead_zone: f64 = 0.015,
        /// Spool position at zero command (null bias), fraction of travel.
        pub null_offset: f64 = 0.0,
        /// Flow gain of the B→T edge relative to the P→A edge (both open for
        /// positive travel). Fitted by calibration.
        pub rod_edge_gain_extend: f64 = 1.0,
        /// Flow gain of the P→B edge relative to the A→T edge.
        pub rod_edge_gain_retract: f64 = 1.0,
        /// Laminar leakage across each of the four covered metering edges
        /// (P→A, A→T, P→B, B→T), l/min per bar. The thesis' per-edge values
        /// of §6.3.1.2 give litres per minute at rest (erratum 2); its
        /// nomenclature value 5.5e-13 m³/(s·Pa) = 3.3e-3 l/min/bar gives
        /// ≈ 0.15 l/min at 50 bar, the order of a D633's null leakage.
        pub edge_leak_lpm_per_bar: f64 = 3.3e-3,
        /// Pressure drop below which orifice flow turns laminar, bar. Keeps
        /// the flow law differentiable at Δp = 0.
        pub laminar_dp_bar: f64 = 1.0,
    }
}

params_struct! {
    /// The hydraulic oil.
    pub struct Fluid {
        /// Bulk modulus of air-free oil, including hose compliance, bar.
        pub bulk_modulus_bar: f64 = 16_000.0,
        /// Entrained air fraction at atmospheric pressure (eq. 6.9, 0–0.15).
        pub air_fraction: f64 = 0.01,
        /// Adiabatic index of the entrained air.
        pub adiabatic_index: f64 = 1.4,
        /// Atmospheric pressure, bar (absolute).
        pub atmospheric_pressure_bar: f64 = 1.013,
        /// Oil temperature the leakage coefficients refer to, °C.
        pub reference_temperature_c: f64 = 25.0,
        /// Viscosity–temperature slope k in ν(T) = ν_ref·exp(−k·(T − T_ref)),
        /// 1/°C. ISO VG 46 mineral oil: ν halves from 25 °C to 40 °C.
        pub viscosity_temperature_coeff_per_c: f64 = 0.045,
    }
}

params_struct! {
    /// Cylinder and crane friction, eq. 6.17 with the sign fixed (erratum 3):
    /// F_f = (F_c + (F_brk − F_c)·e^(−c_v·|v|))·sign(v) + B·v.
    pub struct Friction {
        /// Coulomb friction F_c, N (§7.1 measured ≈ 480 N).
        pub coulomb_n: f64 = 480.0,
        /// Breakaway (static) friction F_brk, N (the thesis table's 990 N).
        pub breakaway_n: f64 = 990.0,
        /// Stribeck decay constant c_v, s/m.
        pub stribeck_s_per_m: f64 = 10.0,
        /// Viscous friction B, N·s/m (the thesis' "N·m·s" is a typo).
        pub viscous_ns_per_m: f64 = 5000.0,
        /// Velocity scale of the model's smooth sign(v) = v/√(v² + v_s²),
        /// m/s. Stands in for stiction: under a net force below breakaway
        /// the model creeps at up to ≈ v_s. Creep displaces oil exactly as
        /// an internal leak does (piston side loses, rod side gains: at
        /// 0.5 mm/s that is 0.09 l/min), so v_s must be small; the implicit
        /// velocity update keeps the resulting stiffness stable.
        pub smoothing_m_s: f64 = 2.0e-5,
    }
}

params_struct! {
    /// Leakage present in a healthy installation, at the reference
    /// temperature. Leaks reported by the monitor are flows above these.
    pub struct Leakage {
        /// Piston seal leakage, piston chamber → rod chamber, l/min per bar.
        /// §6.3.3 gives K_Lp = 1e-12 m³/(s·Pa) = 6e-3 l/min/bar; the
        /// nomenclature's 2.32e-9 would be > 100 l/min (erratum 1).
        pub seal_lpm_per_bar: f64 = 6.0e-3,
        /// Baseline leakage from the rod side to tank, l/min per bar (e.g.
        /// a valve that leaks a little more on one side). Set by
        /// calibration so that a healthy installation reads zero; may be
        /// slightly negative as a correction of the valve's edge leakage.
        pub external_lpm_per_bar: f64 = 0.0,
    }
}

params_struct! {
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
        /// Apparent external leak coefficient per region, l/min at 10 bar
        /// from the rod side to tank.
        pub external_lpm_per_10bar: [f64; 3] = [0.0; 3],
        /// The installation's detection floor per leak `[internal,
        /// external]`, l/min: how far the leak readings of the leak-free
        /// installation still wander (model error the baseline cannot
        /// remove), measured by calibration on a part of its recording it
        /// did not fit. A leak alarms only above the larger of this and
        /// `alarm.alarm_lpm` — the smallest leak this installation can be
        /// trusted to tell. 0: no floor.
        pub detection_floor_lpm: [f64; 2] = [0.0; 2],
    }
}

params_struct! {
    /// The measurement chain.
    pub struct Sensors {
        /// White noise on each pressure reading, bar (1σ).
        pub pressure_noise_bar: f64 = 0.08,
        /// White noise on the position reading, m (1σ).
        pub position_noise_m: f64 = 5.0e-5,
        /// First-order lag of the pressure transmitters, s (MBS 3050: < 4 ms).
        pub pressure_lag_s: f64 = 0.004,
        /// Offsets subtracted from the supply, piston, rod and tank
        /// pressure readings, bar. Fitted by calibration.
        pub pressure_offsets_bar: [f64; 4] = [0.0, 0.0, 0.0, 0.0],
        /// Offset subtracted from the position reading, m.
        pub position_offset_m: f64 = 0.0,
        /// Plausible pressure range, bar: readings outside are sensor faults.
        pub pressure_range_bar: [f64; 2] = [-2.0, 400.0],
        /// Plausible position range beyond the stroke ends, m.
        pub position_margin_m: f64 = 0.01,
        /// Lowest white-noise σ the filters assume for a pressure reading,
        /// bar, whatever the online estimate says (a quantised, noise-free
        /// recording has none at holds).
        pub pressure_noise_floor_bar: f64 = 0.01,
        /// Lowest white-noise σ assumed for the position reading, m.
        pub position_noise_floor_m: f64 = 2.0e-6,
    }
}

params_struct! {
    /// EKF tuning, in the filter's scaled units (the reference scales
    /// `X_REF`, `P_REF`, `GAIN_REF`, `LAMINAR_REF` in `model`): process-noise
    /// intensities are per second.
    pub struct FilterTuning {
        /// Integration substeps per sample for the state prediction.
        pub substeps: u32 = 2,
        /// Process noise on piston position, (scaled unit)²/s.
        pub q_position: f64 = 1.0e-8,
        /// Process noise on piston velocity (unmodelled forces).
        pub q_velocity: f64 = 4.0e-4,
        /// Process noise on spool position (valve model error).
        pub q_spool: f64 = 1.0e-6,
        /// Process noise on spool velocity.
        pub q_spool_rate: f64 = 1.0e-6,
        /// Process noise on chamber pressures (flow model error).
        pub q_pressure: f64 = 4.0e-5,
        /// Random-walk intensity of each valve flow-gain deviation
        /// (relative)²/s: slow, valves drift with wear, not within seconds.
        pub q_gain: f64 = 1.0e-7,
        /// Prior 1σ of each valve flow-gain deviation (relative).
        pub gain_prior: f64 = 0.08,
        /// Random-walk intensity of the healthy laminar-leakage deviation
        /// (relative)²/s: oil warms over minutes (≈ 2 %/√s).
        pub q_laminar: f64 = 4.0e-4,
        /// Prior 1σ of the laminar-leakage deviation (relative): 25 → 40 °C
        /// without a temperature reading is +100 %.
        pub laminar_prior: f64 = 0.5,
        /// Random-walk intensity of each leak coefficient, (l/min at 10 bar)²/s.
        pub q_leak: f64 = 5.0e-3,
        /// Prior 1σ of each leak coefficient, l/min at 10 bar.
        pub leak_prior_lpm: f64 = 0.1,
        /// Time constant of the evidence memory and of the reported leak
        /// size average, s.
        pub evidence_window_s: f64 = 4.0,
        /// Time constant of the leak-flow average used for detection, s.
        pub detection_window_s: f64 = 0.25,
        /// Residual correlation length, samples: log-likelihoods are divided
        /// by it (consecutive model residuals are not independent).
        pub residual_correlation_samples: f64 = 50.0,
        /// Log-likelihood charged per leak state and second of evidence
        /// (nested hypotheses: a free leak always fits a little better).
        pub complexity_penalty_per_s: f64 = 2.0,
        /// After a (re)start no alarm is raised for this long while the
        /// filters converge, s. Short enough that a 10 s valve step test
        /// (step at 3 s) ends conclusive.
        pub warm_up_s: f64 = 2.0,
        /// Estimated chamber-pressure rate at which a sample counts half as
        /// evidence and the valve and leak parameters learn at half weight,
        /// bar/s (see `quiet.rs`; 0 disables the weighting).
        pub quiet_rate_bar_s: f64 = 10.0,
        /// Valve metering flow at which a sample counts half as evidence and
        /// the leak states learn at half weight, l/min.
        pub quiet_flow_lpm: f64 = 10.0,
        /// Valve metering flow at which the valve flow-gain states learn at
        /// half weight, l/min (they are not observable at holds).
        pub gain_learning_flow_lpm: f64 = 2.0,
        /// Time constant with which learning resumes after a transient, s.
        pub learning_recovery_s: f64 = 0.3,
        /// Nominal sample period, s; gaps over 5 periods re-initialise.
        pub sample_period_s: f64 = 0.001,
        /// Time constant of the online estimate of each reading's noise, s
        /// (`signal::noise`); `sensors.*_noise_*` are its starting values.
        pub noise_time_constant_s: f64 = 2.0,
        /// Evidence-weighted time the filters must have seen after the
        /// warm-up before the monitor claims `healthy`, s.
        pub min_evidence_s: f64 = 0.5,
        /// Time constant of the recent evidence weight, s: when its average
        /// falls below `min_evidence_fraction` the verdict is
        /// `inconclusive` (too little quasi-steady operation for too long).
        pub evidence_memory_s: f64 = 30.0,
        /// See `evidence_memory_s`.
        pub min_evidence_fraction: f64 = 0.05,
    }
}

params_struct! {
    /// When to warn and alarm.
    pub struct AlarmConfig {
        /// Leak flow that raises a warning, l/min (on the reported average).
        pub warning_lpm: f64 = 0.05,
        /// Leak flow that raises the alarm, l/min. The default sits below
        /// 0.1 l/min so that leaks of 0.1 l/min are caught, and above the
        /// largest healthy reading seen in evaluation (≈ 0.07 l/min).
        pub alarm_lpm: f64 = 0.08,
        /// CUSUM decision interval, s: an alarm is raised when the time
        /// integral of the relative excess over the alarm level reaches it
        /// (this long at twice the alarm level).
        pub debounce_s: f64 = 0.5,
        /// Minimum posterior probability of the leak hypothesis.
        pub min_probability: f64 = 0.9,
    }
}

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
}

/// Operating region of a valve command for `[baseline]`: 0 retracting
/// (u < null − dead zone), 1 holding, 2 extending (u > null + dead zone).
/// `hold_band` is [`Params::hold_band`].
pub fn operating_region(u: f32, hold_band: (f32, f32)) -> usize {
    if u < hold_band.0 {
        0
    } else if u > hold_band.1 {
        2
    } else {
        1
    }
}

impl Params {
    /// The valve commands of the holding region: null ± dead zone.
    pub fn hold_band(&self) -> (f32, f32) {
        let v = &self.valve;
        (
            (v.null_offset - v.dead_zone) as f32,
            (v.null_offset + v.dead_zone) as f32,
        )
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
    };

    /// The reference thesis rig (ch. 5–6).
    pub fn nominal() -> Self {
        Self::NOMINAL
    }

    /// Check that every value is finite and physically meaningful. Returns
    /// the first offending field's name.
    pub fn validate(&self) -> Result<(), ParamError> {
        let positive: [(&'static str, f64); 33] = [
            ("cylinder.piston_area_m2", self.cylinder.piston_area_m2),
            ("cylinder.rod_side_area_m2", self.cylinder.rod_side_area_m2),
            ("cylinder.stroke_m", self.cylinder.stroke_m),
            (
                "cylinder.dead_volume_piston_m3",
                self.cylinder.dead_volume_piston_m3,
            ),
            (
                "cylinder.dead_volume_rod_m3",
                self.cylinder.dead_volume_rod_m3,
            ),
            ("load.gravity_scale", self.load.gravity_scale),
            ("load.inertia_scale", self.load.inertia_scale),
            (
                "valve.rod_edge_gain_extend",
                self.valve.rod_edge_gain_extend,
            ),
            (
                "valve.rod_edge_gain_retract",
                self.valve.rod_edge_gain_retract,
            ),
            (
                "valve.natural_frequency_rad_s",
                self.valve.natural_frequency_rad_s,
            ),
            ("valve.damping_ratio", self.valve.damping_ratio),
            (
                "valve.flow_gain_extend_lpm_sqrt_bar",
                self.valve.flow_gain_extend_lpm_sqrt_bar,
            ),
            (
                "valve.flow_gain_retract_lpm_sqrt_bar",
                self.valve.flow_gain_retract_lpm_sqrt_bar,
            ),
            ("valve.laminar_dp_bar", self.valve.laminar_dp_bar),
            ("fluid.bulk_modulus_bar", self.fluid.bulk_modulus_bar),
            ("fluid.adiabatic_index", self.fluid.adiabatic_index),
            (
                "fluid.atmospheric_pressure_bar",
                self.fluid.atmospheric_pressure_bar,
            ),
            ("friction.smoothing_m_s", self.friction.smoothing_m_s),
            (
                "sensors.pressure_noise_bar",
                self.sensors.pressure_noise_bar,
            ),
            ("sensors.position_noise_m", self.sensors.position_noise_m),
            ("filter.leak_prior_lpm", self.filter.leak_prior_lpm),
            ("filter.quiet_flow_lpm", self.filter.quiet_flow_lpm),
            (
                "filter.gain_learning_flow_lpm",
                self.filter.gain_learning_flow_lpm,
            ),
            ("filter.evidence_window_s", self.filter.evidence_window_s),
            ("filter.detection_window_s", self.filter.detection_window_s),
            (
                "filter.residual_correlation_samples",
                self.filter.residual_correlation_samples,
            ),
            (
                "filter.complexity_penalty_per_s",
                self.filter.complexity_penalty_per_s,
            ),
            ("filter.sample_period_s", self.filter.sample_period_s),
            (
                "filter.noise_time_constant_s",
                self.filter.noise_time_constant_s,
            ),
            ("filter.evidence_memory_s", self.filter.evidence_memory_s),
            (
                "sensors.pressure_noise_floor_bar",
                self.sensors.pressure_noise_floor_bar,
            ),
            (
                "sensors.position_noise_floor_m",
                self.sensors.position_noise_floor_m,
            ),
            ("alarm.alarm_lpm", self.alarm.alarm_lpm),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(ParamError {
                    field: name,
                    problem: "must be a finite number > 0",
                });
            }
        }
        let non_negative: [(&'static str, f64); 22] = [
            ("valve.dead_zone", self.valve.dead_zone),
            (
                "valve.edge_leak_lpm_per_bar",
                self.valve.edge_leak_lpm_per_bar,
            ),
            ("fluid.air_fraction", self.fluid.air_fraction),
            (
                "fluid.viscosity_temperature_coeff_per_c",
                self.fluid.viscosity_temperature_coeff_per_c,
            ),
            ("friction.coulomb_n", self.friction.coulomb_n),
            ("friction.breakaway_n", self.friction.breakaway_n),
            ("friction.stribeck_s_per_m", self.friction.stribeck_s_per_m),
            ("friction.viscous_ns_per_m", self.friction.viscous_ns_per_m),
            ("leakage.seal_lpm_per_bar", self.leakage.seal_lpm_per_bar),
            ("sensors.pressure_lag_s", self.sensors.pressure_lag_s),
            ("filter.q_position", self.filter.q_position),
            ("filter.q_velocity", self.filter.q_velocity),
            ("filter.q_spool", self.filter.q_spool),
            ("filter.q_spool_rate", self.filter.q_spool_rate),
            ("filter.q_pressure", self.filter.q_pressure),
            ("filter.q_leak", self.filter.q_leak),
            ("filter.q_laminar", self.filter.q_laminar),
            ("filter.laminar_prior", self.filter.laminar_prior),
            ("filter.q_gain", self.filter.q_gain),
            ("filter.gain_prior", self.filter.gain_prior),
            ("filter.warm_up_s", self.filter.warm_up_s),
            ("filter.min_evidence_s", self.filter.min_evidence_s),
        ];
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ParamError {
                    field: name,
                    problem: "must be a finite number ≥ 0",
                });
            }
        }
        let finite: [(&'static str, f64); 5] = [
            ("load.force_offset_n", self.load.force_offset_n),
            ("valve.null_offset", self.valve.null_offset),
            ("sensors.position_offset_m", self.sensors.position_offset_m),
            (
                "fluid.reference_temperature_c",
                self.fluid.reference_temperature_c,
            ),
            ("load.gravity_m_s2", self.load.gravity_m_s2),
        ];
        for (name, v) in finite {
            if !v.is_finite() {
                return Err(ParamError {
                    field: name,
                    problem: "must be a finite number",
                });
            }
        }
        let ext = self.leakage.external_lpm_per_bar;
        if !(ext.is_finite() && ext > -0.01 && ext < 1.0) {
            return Err(ParamError {
                field: "leakage.external_lpm_per_bar",
                problem: "must be finite, > -0.01 and < 1",
            });
        }
        if !(self.fluid.air_fraction < 0.5) {
            return Err(ParamError {
                field: "fluid.air_fraction",
                problem: "must be < 0.5",
            });
        }
        if !(self.valve.dead_zone < 0.5) {
            return Err(ParamError {
                field: "valve.dead_zone",
                problem: "must be < 0.5",
            });
        }
        if !(self.cylinder.rod_side_area_m2 < self.cylinder.piston_area_m2) {
            return Err(ParamError {
                field: "cylinder.rod_side_area_m2",
                problem: "must be smaller than the piston area",
            });
        }
        if !(1..=16).contains(&self.filter.substeps) {
            return Err(ParamError {
                field: "filter.substeps",
                problem: "must be 1..=16",
            });
        }
        if !(self.alarm.warning_lpm.is_finite()
            && self.alarm.warning_lpm > 0.0
            && self.alarm.warning_lpm <= self.alarm.alarm_lpm)
        {
            return Err(ParamError {
                field: "alarm.warning_lpm",
                problem: "must be > 0 and ≤ alarm.alarm_lpm",
            });
        }
        if !(self.alarm.debounce_s.is_finite() && self.alarm.debounce_s >= 0.0) {
            return Err(ParamError {
                field: "alarm.debounce_s",
                problem: "must be ≥ 0",
            });
        }
        if !(self.filter.min_evidence_fraction >= 0.0 && self.filter.min_evidence_fraction < 1.0) {
            return Err(ParamError {
                field: "filter.min_evidence_fraction",
                problem: "must be in [0, 1)",
            });
        }
        if !(self.alarm.min_probability > 0.0 && self.alarm.min_probability < 1.0) {
            return Err(ParamError {
                field: "alarm.min_probability",
                problem: "must be in (0, 1)",
            });
        }
        let [lo, hi] = self.sensors.pressure_range_bar;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(ParamError {
                field: "sensors.pressure_range_bar",
                problem: "must be [low, high] with low < high",
            });
        }
        for (name, arr) in [
            (
                "baseline.internal_lpm_per_10bar",
                &self.baseline.internal_lpm_per_10bar,
            ),
            (
                "baseline.external_lpm_per_10bar",
                &self.baseline.external_lpm_per_10bar,
            ),
        ] {
            if arr.iter().any(|v| !(v.is_finite() && v.abs() < 1.0)) {
                return Err(ParamError {
                    field: name,
                    problem: "entries must be finite and within ±1 l/min at 10 bar",
                });
            }
        }
        if self
            .baseline
            .detection_floor_lpm
            .iter()
            .any(|v| !(v.is_finite() && (0.0..=10.0).contains(v)))
        {
            return Err(ParamError {
                field: "baseline.detection_floor_lpm",
                problem: "entries must be within 0..=10 l/min",
            });
        }
        for (name, arr) in [
            ("load.masses_kg", &self.load.masses_kg),
            ("load.inertias_kg_m2", &self.load.inertias_kg_m2),
        ] {
            if arr.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
                return Err(ParamError {
                    field: name,
                    problem: "entries must be finite and ≥ 0",
                });
            }
        }
        if self
            .sensors
            .pressure_offsets_bar
            .iter()
            .any(|v| !v.is_finite())
        {
            return Err(ParamError {
                field: "sensors.pressure_offsets_bar",
                problem: "entries must be finite",
            });
        }
        Ok(())
    }
}

/// A parameter set that cannot describe a real installation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ParamError {
    /// The offending field, as `section.field`.
    pub field: &'static str,
    /// What is wrong with it.
    pub problem: &'static str,
}

impl core::fmt::Display for ParamError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "parameter `{}` {}", self.field, self.problem)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nominal_is_valid() {
        Params::nominal().validate().unwrap();
    }

    #[test]
    fn rejects_nonsense_naming_the_field() {
        let mut p = Params::nominal();
        p.cylinder.rod_side_area_m2 = 4e-3;
        assert_eq!(p.validate().unwrap_err().field, "cylinder.rod_side_area_m2");
        let mut p = Params::nominal();
        p.fluid.bulk_modulus_bar = f64::NAN;
        assert_eq!(p.validate().unwrap_err().field, "fluid.bulk_modulus_bar");
        let mut p = Params::nominal();
        p.alarm.warning_lpm = 0.5;
        assert_eq!(p.validate().unwrap_err().field, "alarm.warning_lpm");
    }

    #[test]
    fn thesis_unit_conversions() {
        // K_v1 = 4.165e-7 m³/(s·√Pa) in l/min/√bar.
        let kv = 4.165e-7 * 60_000.0 * 1e5_f64.sqrt();
        assert!((kv - Valve::NOMINAL.flow_gain_extend_lpm_sqrt_bar).abs() < 1e-3);
        let kv2 = 3.91e-7 * 60_000.0 * 1e5_f64.sqrt();
        assert!((kv2 - Valve::NOMINAL.flow_gain_retract_lpm_sqrt_bar).abs() < 1e-3);
        // K_Lp = 1e-12 m³/(s·Pa) in l/min/bar.
        assert!((1e-12 * 60_000.0 * 1e5 - Leakage::NOMINAL.seal_lpm_per_bar).abs() < 1e-9);
        // Slender-bar inertias m·(2d)²/12.
        let p = Pantograph::NOMINAL;
        let d = [
            p.r1_to_cg1_m,
            p.r21_to_cg21_m,
            p.r22_to_cg22_m,
            p.r3_to_cg3_m,
        ];
        for i in 0..4 {
            let want = p.masses_kg[i] * (2.0 * d[i]) * (2.0 * d[i]) / 12.0;
            assert!((want - p.inertias_kg_m2[i]).abs() < 1e-4, "rod {i}: {want}");
        }
    }

    #[cfg(feature = "serde")]
    #[test]
    fn partial_toml_overrides_only_what_it_names() {
        extern crate std;
        use std::string::ToString;
        let p: Params = toml::from_str("[valve]\nnull_offset = 0.002\n").unwrap();
        assert_eq!(p.valve.null_offset, 0.002);
        assert_eq!(p.cylinder, Cylinder::NOMINAL);
        let err = toml::from_str::<Params>("[valve]\nnul_offset = 0.002\n").unwrap_err();
        assert!(err.to_string().contains("nul_offset"), "{err}");
    }
}
