//! A quad-X quadrotor as a rigid body driven by its four motors: what iNav's own
//! mixer, PIDs and ANGLE mode fly when iNav SITL is in the loop (`faithd-lab`'s
//! RealFlight server hands it iNav's motor outputs and iNav the state it reads back).
//!
//! Motor numbers and spins are iNav 9.1's Quad X (the Configurator's preset written
//! as `mmix` rules; src/main/flight/mixer.c:540 applies the yaw weight): 1 rear right
//! spinning clockwise seen from above, 2 front right counter-clockwise, 3 rear left
//! counter-clockwise, 4 front left clockwise. A motor's command is iNav's output
//! scaled as iNav sends it to RealFlight, (us - 1000) / 1000: 0 stopped, 0.08 armed
//! idle, 1 full. Thrust grows with the square of the rotor speed, which follows the
//! command with a first-order lag; the reaction torque of each prop yaws the frame.
//!
//! Frames: world NED (x north, z down), body FRD, as [`VehicleState`]. Pure: stepped
//! with an explicit time step.

use nalgebra::{Rotation3, Vector3};

use super::trajectory::VehicleState;

/// Standard gravity, m/s^2 (what iNav calls 1 g, src/main/sensors/acceleration.h).
pub const G_M_S2: f64 = 9.80665;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadXConfig {
    pub mass_kg: f64,
    /// From the centre to each motor, metres (motors on the diagonals).
    pub arm_m: f64,
    /// Moments of inertia about body x, y and z, kg m^2.
    pub inertia_kg_m2: [f64; 3],
    /// One motor's thrust at full command, newtons.
    pub max_thrust_n: f64,
    /// Reaction torque of a prop per newton of its thrust, metres.
    pub yaw_torque_m: f64,
    /// Time constant of a rotor's speed following its command, seconds.
    pub motor_lag_s: f64,
    /// Air drag, newtons per (m/s)^2 of airspeed.
    pub drag_n_per_m2_s2: f64,
    /// Rotor drag: the spinning props resist horizontal motion in proportion to it
    /// (blade flapping and induced drag), per second. About 0.3/s is the order
    /// identified on small quadrotors (Faessler, Franchi and Scaramuzza, "Differential
    /// flatness of quadrotor dynamics subject to rotor drag", RA-L 2018); at the
    /// speeds of an approach (2 m/s) it is four times the air drag.
    pub rotor_drag_per_s: f64,
    /// Aerodynamic damping of body rates, newton metres per rad/s.
    pub rate_damping_nm_s: f64,
}

impl Default for QuadXConfig {
    /// A 5-inch quad of 600 g with a thrust-to-weight ratio of 4: it hovers at half
    /// command (1500 us, iNav's default `nav_mc_hover_thr`).
    fn default() -> Self {
        let mass_kg = 0.6;
        Self {
            mass_kg,
            arm_m: 0.11,
            inertia_kg_m2: [3.0e-3, 3.0e-3, 5.5e-3],
            max_thrust_n: mass_kg * G_M_S2,
            yaw_torque_m: 0.016,
            motor_lag_s: 0.03,
            drag_n_per_m2_s2: 0.03,
            rotor_drag_per_s: 0.3,
            rate_damping_nm_s: 2.0e-3,
        }
    }
}

/// Where each motor sits, body FRD (x forward, y right), in iNav's order.
const MOTOR_CORNERS: [(f64, f64); 4] = [(-1.0, 1.0), (1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)];
/// Each motor's reaction torque about body z (+ nose right): the counter-clockwise
/// props (2 and 3) turn the frame clockwise.
const MOTOR_YAW_SIGN: [f64; 4] = [-1.0, 1.0, 1.0, -1.0];

#[derive(Clone, Debug, PartialEq)]
pub struct QuadX {
    pub config: QuadXConfig,
    pub t_s: f64,
    /// World NED, metres; the ground is at z = 0.
    pub position_m: Vector3<f64>,
    pub velocity_m_s: Vector3<f64>,
    /// Body to world.
    pub attitude: Rotation3<f64>,
    /// FRD body rates, rad/s.
    pub body_rates_rad_s: Vector3<f64>,
    /// Each rotor's speed as a fraction of full.
    pub rotor: [f64; 4],
    /// What an accelerometer on the frame reads (body FRD, m/s^2): the specific force,
    /// -g on z when at rest and level.
    pub specific_force_m_s2: Vector3<f64>,
    /// Resting on the ground (no thrust lifts it).
    pub on_ground: bool,
}

impl QuadX {
    /// At rest on the ground at `position_m` (its z is taken as 0), level, facing
    /// `heading_rad` (clockwise from north), motors stopped.
    pub fn on_ground(config: QuadXConfig, position_m: Vector3<f64>, heading_rad: f64) -> Self {
        Self {
            config,
            t_s: 0.0,
            position_m: Vector3::new(position_m.x, position_m.y, 0.0),
            velocity_m_s: Vector3::zeros(),
            attitude: Rotation3::from_euler_angles(0.0, 0.0, heading_rad),
            body_rates_rad_s: Vector3::zeros(),
            rotor: [0.0; 4],
            specific_force_m_s2: Vector3::new(0.0, 0.0, -G_M_S2),
            on_ground: true,
        }
    }

    /// Each motor's thrust now, newtons.
    pub fn thrust_n(&self) -> [f64; 4] {
        self.rotor.map(|w| self.config.max_thrust_n * w * w)
    }

    /// Advances by `dt_s` with `motors` commanded (each clamped to 0..1).
    pub fn step(&mut self, motors: [f64; 4], dt_s: f64) {
        let c = self.config;
        let follow = (dt_s / c.motor_lag_s).min(1.0);
        for (w, u) in self.rotor.iter_mut().zip(motors) {
            let u = if u.is_finite() {
                u.clamp(0.0, 1.0)
            } else {
                0.0
            };
            *w += (u - *w) * follow;
        }
        let thrust = self.thrust_n();
        let total_n: f64 = thrust.iter().sum();

        // Rotation: Euler's equations with the motors' torques and rate damping.
        let corner_m = c.arm_m / std::f64::consts::SQRT_2;
        let mut torque = Vector3::zeros();
        for i in 0..4 {
            let (x, y) = MOTOR_CORNERS[i];
            // r x F with F = (0, 0, -T): (-y T, x T, 0).
            torque.x -= y * corner_m * thrust[i];
            torque.y += x * corner_m * thrust[i];
            torque.z += MOTOR_YAW_SIGN[i] * c.yaw_torque_m * thrust[i];
        }
        let w = self.body_rates_rad_s;
        torque -= w * c.rate_damping_nm_s;
        let inertia = Vector3::from(c.inertia_kg_m2);
        let momentum = inertia.component_mul(&w);
        let w_dot = (torque - w.cross(&momentum)).component_div(&inertia);

        // Translation: thrust along body -z, drag against the airspeed, rotor drag
        // against the horizontal speed, gravity.
        let gravity = Vector3::new(0.0, 0.0, G_M_S2);
        let thrust_world = self.attitude * Vector3::new(0.0, 0.0, -total_n);
        let v = self.velocity_m_s;
        let rotor_drag = -Vector3::new(v.x, v.y, 0.0) * c.rotor_drag_per_s * c.mass_kg;
        let drag = -v * v.norm() * c.drag_n_per_m2_s2 + rotor_drag;
        let mut accel = (thrust_world + drag) / c.mass_kg + gravity;

        let resting = self.position_m.z >= 0.0 && accel.z >= 0.0 && v.z >= 0.0;
        if resting {
            // The ground holds it: no sinking, no sliding, no tipping while it sits.
            self.on_ground = true;
            accel = Vector3::zeros();
            self.velocity_m_s = Vector3::zeros();
            self.body_rates_rad_s = Vector3::zeros();
            let (_, _, yaw) = self.attitude.euler_angles();
            self.attitude = Rotation3::from_euler_angles(0.0, 0.0, yaw);
            self.position_m.z = 0.0;
        } else {
            self.on_ground = false;
            self.body_rates_rad_s += w_dot * dt_s;
            self.attitude *= Rotation3::new(self.body_rates_rad_s * dt_s);
            self.attitude.renormalize();
            self.velocity_m_s += accel * dt_s;
            self.position_m += self.velocity_m_s * dt_s;
            if self.position_m.z > 0.0 {
                // Touched down: it stops there.
                self.position_m.z = 0.0;
                self.velocity_m_s.z = self.velocity_m_s.z.min(0.0);
            }
        }
        self.specific_force_m_s2 = self.attitude.inverse() * (accel - gravity);
        self.t_s += dt_s;
    }

    /// Roll and pitch in radians (pitch positive nose up), heading clockwise from north.
    pub fn euler_rad(&self) -> (f64, f64, f64) {
        self.attitude.euler_angles()
    }

    /// How far the body's z axis leans from the vertical, radians (over pi/2: upside down).
    pub fn tilt_rad(&self) -> f64 {
        let down = self.attitude * Vector3::z();
        down.z.clamp(-1.0, 1.0).acos()
    }

    pub fn state(&self) -> VehicleState {
        VehicleState {
            t_s: self.t_s,
            position_m: self.position_m,
            velocity_m_s: self.velocity_m_s,
            attitude: self.attitude,
            body_rates_rad_s: self.body_rates_rad_s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT_S: f64 = 0.001;

    fn flying() -> QuadX {
        let mut q = QuadX::on_ground(QuadXConfig::default(), Vector3::zeros(), 0.0);
        q.position_m.z = -10.0;
        q.on_ground = false;
        q.rotor = [0.5; 4];
        q
    }

    fn fly(q: &mut QuadX, motors: [f64; 4], seconds: f64) {
        for _ in 0..(seconds / DT_S).round() as usize {
            q.step(motors, DT_S);
        }
    }

    #[test]
    fn half_command_hovers_and_less_sinks_to_the_ground_and_sits() {
        let mut q = flying();
        fly(&mut q, [0.5; 4], 2.0);
        assert!((q.position_m.z + 10.0).abs() < 1e-6, "{}", q.position_m.z);
        assert!((q.specific_force_m_s2.z + G_M_S2).abs() < 1e-6);
        fly(&mut q, [0.4; 4], 10.0);
        assert!(q.on_ground && q.position_m.z == 0.0, "{q:?}");
        assert!((q.specific_force_m_s2 - Vector3::new(0.0, 0.0, -G_M_S2)).norm() < 1e-9);
    }

    #[test]
    fn more_thrust_on_the_left_rolls_right_and_on_the_rear_pitches_down() {
        // iNav's mixer: a right roll raises the left motors (3, 4), nose down the rear
        // ones (1, 3).
        let mut q = flying();
        fly(&mut q, [0.5, 0.5, 0.52, 0.52], 0.1);
        assert!(q.body_rates_rad_s.x > 0.1, "{:?}", q.body_rates_rad_s);
        let (roll, _, _) = q.euler_rad();
        assert!(roll > 0.0);
        let mut q = flying();
        fly(&mut q, [0.52, 0.5, 0.52, 0.5], 0.1);
        let (_, pitch, _) = q.euler_rad();
        assert!(q.body_rates_rad_s.y < -0.1 && pitch < 0.0, "{pitch}");
    }

    #[test]
    fn the_counter_clockwise_props_yaw_the_frame_clockwise() {
        let mut q = flying();
        fly(&mut q, [0.5, 0.55, 0.55, 0.5], 0.2);
        assert!(q.body_rates_rad_s.z > 0.05, "{:?}", q.body_rates_rad_s);
        let (roll, pitch, _) = q.euler_rad();
        assert!(roll.abs() < 1e-9 && pitch.abs() < 1e-9);
    }

    #[test]
    fn a_bank_accelerates_it_sideways_and_drag_bounds_the_speed() {
        let mut q = flying();
        q.attitude = Rotation3::from_euler_angles(20f64.to_radians(), 0.0, 0.0);
        // Enough thrust to hold height at 20 degrees of bank.
        let u = (1.0 / 20f64.to_radians().cos()).sqrt() * 0.5;
        fly(&mut q, [u; 4], 20.0);
        assert!(q.velocity_m_s.y > 3.0, "{:?}", q.velocity_m_s);
        assert!(q.velocity_m_s.z.abs() < 0.05, "{:?}", q.velocity_m_s);
        // Terminal: air and rotor drag balance g tan(20 deg):
        // c v^2 + m k v = m g tan(20 deg).
        let (c, m, k) = (
            q.config.drag_n_per_m2_s2,
            q.config.mass_kg,
            q.config.rotor_drag_per_s,
        );
        let push_n = m * G_M_S2 * 20f64.to_radians().tan();
        let terminal = (-m * k + ((m * k).powi(2) + 4.0 * c * push_n).sqrt()) / (2.0 * c);
        assert!((q.velocity_m_s.y - terminal).abs() < 0.05 * terminal);
    }

    #[test]
    fn stopped_motors_on_the_ground_stay_put_and_level() {
        let mut q = QuadX::on_ground(QuadXConfig::default(), Vector3::new(3.0, 4.0, 0.0), 1.0);
        fly(&mut q, [0.08; 4], 3.0);
        assert!(q.on_ground);
        assert_eq!(q.position_m, Vector3::new(3.0, 4.0, 0.0));
        assert!((q.euler_rad().2 - 1.0).abs() < 1e-12);
        assert!(q.tilt_rad() < 1e-9);
    }
}
