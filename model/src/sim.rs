//! The lander simulation (SPEC §1): one tick of physics, the asymmetric
//! rotation wrap, the x wrap and the 30-point hull impact test.
//!
//! Speed comes from exact shortcuts, all checked against
//! [`crate::reference`] bit for bit:
//! - `sin`, `cos` and the hull's lowest point depend only on `rot`, which
//!   changes only on rotate ticks. They are recomputed lazily, when a thrust
//!   tick or a ground check needs them, never per tick.
//! - The hull cannot reach the touchdown line while the centre is higher
//!   than the hull's radius above it, so up there the test is one compare.
//! - Near the ground, a lowest point known at one rotation bounds it at
//!   another: a point at radius `r` moves at most `r·|Δrot|`. The exact
//!   minimum is recomputed only when that bound cannot rule touchdown out.
//! - Because IEEE addition is monotonic, `y + min(offsets)` equals
//!   `min(y + offset)` exactly.
//! - A run meets few distinct rotations (each a sum of rotation steps), so
//!   `sin_cos` and the hull's lowest point are remembered per thread, by
//!   the rotation's bits (`trig`).

use crate::score;
use crate::{Action, Env, Gene, Outcome, State};
use std::f64::consts::{PI, TAU};

/// The hull in model units, in the original's order.
pub const HULL: [(f64, f64); 30] = [
    (-1.0, 0.0),
    (1.0, 0.0),
    (1.0, -0.5),
    (-1.0, -0.5),
    (-0.5, 0.0),
    (-1.0, 0.3),
    (-1.0, 0.7),
    (-0.5, 1.0),
    (0.5, 1.0),
    (1.0, 0.7),
    (1.0, 0.3),
    (0.5, 0.0),
    (-1.0, -0.4),
    (-1.3, -0.8),
    (-1.3, -1.2),
    (-1.5, -1.2),
    (-1.1, -1.2),
    (-0.9, -0.5),
    (-1.3, -0.8),
    (1.0, -0.4),
    (1.3, -0.8),
    (1.3, -1.2),
    (1.5, -1.2),
    (1.1, -1.2),
    (0.9, -0.5),
    (1.3, -0.8),
    (-0.2, -0.5),
    (-0.3, -0.8),
    (0.3, -0.8),
    (0.2, -0.5),
];

/// The constants of a world, unpacked once for the flight loop.
#[derive(Clone, Copy, Debug)]
pub struct Physics {
    width: f64,
    ground_y: f64,
    /// Above this centre height no hull point can be below the ground.
    clear_y: f64,
    hull_scale: f64,
    /// The hull's radius in pixels: no point moves faster than this per
    /// radian of rotation.
    reach: f64,
    rotation_step: f64,
    thrust: f64,
    gravity: f64,
    max_ticks: u32,
}

impl Physics {
    pub fn new(env: &Env) -> Physics {
        let w = &env.world;
        let reach = w.hull_scale.abs() * HULL_RADIUS;
        Physics {
            width: w.width,
            ground_y: w.ground_y,
            clear_y: w.ground_y + reach * 1.001 + 1e-9,
            hull_scale: w.hull_scale,
            reach,
            rotation_step: w.rotation_step,
            thrust: w.thrust_per_tick(),
            gravity: w.gravity_per_tick(),
            max_ticks: w.max_ticks,
        }
    }
}

/// A flight in progress: the state and the cached functions of its
/// rotation. Small and `Copy`, so the guided pass can branch it four ways
/// per gene cheaply; the constants stay behind in [`Physics`].
#[derive(Clone, Copy, Debug)]
pub struct Flight {
    pub state: State,
    pub ticks: u32,
    touched_down: bool,
    // `sin` and `cos` of `trig_rot`; NaN means never computed.
    trig_rot: f64,
    sin: f64,
    cos: f64,
    // The lowest hull point's offset from the centre at `hull_rot`.
    hull_rot: f64,
    hull_low: f64,
}

impl Flight {
    /// The start of a flight: upside down, at rest, at `(x0, H - 50)`.
    pub fn start(env: &Env) -> Flight {
        Flight::at(
            State {
                x: env.x0,
                y: env.world.start_y(),
                vx: 0.0,
                vy: 0.0,
                rot: PI,
            },
            0,
        )
    }

    /// A flight in `state` with `ticks` already flown.
    pub fn at(state: State, ticks: u32) -> Flight {
        Flight {
            state,
            ticks,
            touched_down: false,
            trig_rot: f64::NAN,
            sin: 0.0,
            cos: 0.0,
            hull_rot: f64::NAN,
            hull_low: 0.0,
        }
    }

    pub fn touched_down(&self) -> bool {
        self.touched_down
    }

    /// True once the lander is down or has used up its ticks.
    pub fn ended(&self, p: &Physics) -> bool {
        self.touched_down || self.ticks >= p.max_ticks
    }

    /// Flies up to `ticks` ticks of `action`, stopping early at touchdown
    /// or at the tick guard. Returns the ticks actually flown.
    pub fn run(&mut self, p: &Physics, action: Action, ticks: u32) -> u32 {
        if self.touched_down {
            return 0;
        }
        let ticks = ticks.min(p.max_ticks.saturating_sub(self.ticks));
        match action {
            Action::RotateLeft => self.repeat(p, ticks, Self::rotate_left),
            Action::RotateRight => self.repeat(p, ticks, Self::rotate_right),
            Action::Thrust => self.repeat(p, ticks, Self::thrust),
            Action::Drift => self.repeat(p, ticks, |_, _| {}),
        }
    }

    /// Drifts until touchdown or the tick guard.
    pub fn drift_to_end(&mut self, p: &Physics) {
        self.run(p, Action::Drift, u32::MAX);
    }

    /// Flies every gene in order, stopping at touchdown.
    pub fn run_genes(&mut self, p: &Physics, genes: &[Gene]) {
        for gene in genes {
            self.run(p, gene.action, u32::from(gene.duration));
            if self.ended(p) {
                break;
            }
        }
    }

    /// Scores the flight as it stands, with `n` decoded ticks flown.
    pub fn outcome(&self, env: &Env, n: u32) -> Outcome {
        let safe = self.touched_down && score::is_safe(env, &self.state);
        Outcome {
            state: self.state,
            ticks: self.ticks,
            n,
            touched_down: self.touched_down,
            safe,
            fitness: score::fitness(env, &self.state, n, safe),
        }
    }

    #[inline(always)]
    fn repeat(&mut self, p: &Physics, ticks: u32, act: impl Fn(&mut Self, &Physics)) -> u32 {
        for flown in 1..=ticks {
            act(self, p);
            if self.finish_tick(p) {
                return flown;
            }
        }
        ticks
    }

    #[inline(always)]
    fn rotate_left(&mut self, p: &Physics) {
        self.state.rot = turned_left(p, self.state.rot);
    }

    #[inline(always)]
    fn rotate_right(&mut self, p: &Physics) {
        self.state.rot = turned_right(p, self.state.rot);
    }

    #[inline(always)]
    fn thrust(&mut self, p: &Physics) {
        self.refresh_trig();
        self.state.vx += p.thrust * self.sin;
        self.state.vy += p.thrust * self.cos;
    }

    /// Gravity, move, wrap and the impact test. Returns true at touchdown.
    #[inline(always)]
    fn finish_tick(&mut self, p: &Physics) -> bool {
        motion(p, &mut self.state);
        self.ticks += 1;
        if self.state.y < p.clear_y {
            self.touched_down = self.hull_below_ground(p);
        }
        self.touched_down
    }

    /// The impact test near the ground.
    #[inline(always)]
    fn hull_below_ground(&mut self, p: &Physics) -> bool {
        self.hull_below(p, self.state.y)
    }

    /// The impact test with the centre at height `y` and this flight's own
    /// rotation.
    #[inline(always)]
    fn hull_below(&mut self, p: &Physics, y: f64) -> bool {
        let rot = self.state.rot;
        if rot != self.hull_rot {
            // The margin dwarfs the rounding in the offsets; a NaN `hull_rot`
            // fails the test and forces the exact path.
            let lowest = self.hull_low - p.reach * (rot - self.hull_rot).abs() - 1e-9;
            if y + lowest >= p.ground_y {
                return false;
            }
            self.hull_low = trig::lowest_at(p.hull_scale, rot);
            self.hull_rot = rot;
        }
        y + self.hull_low < p.ground_y
    }

    #[inline(always)]
    fn refresh_trig(&mut self) {
        if self.state.rot != self.trig_rot {
            (self.sin, self.cos) = trig::sin_cos(self.state.rot);
            self.trig_rot = self.state.rot;
        }
    }
}

/// `rot` after a rotate-left tick, wrapped below −π (SPEC §1's asymmetric
/// wrap).
#[inline(always)]
fn turned_left(p: &Physics, rot: f64) -> f64 {
    let rot = rot - p.rotation_step;
    if rot < -PI {
        // A predicted branch, not a select: see `motion`.
        std::hint::cold_path();
        rot + TAU
    } else {
        rot
    }
}

/// `rot` after a rotate-right tick, wrapped only above 2π.
#[inline(always)]
fn turned_right(p: &Physics, rot: f64) -> f64 {
    let rot = rot + p.rotation_step;
    if rot > TAU {
        std::hint::cold_path();
        rot - TAU
    } else {
        rot
    }
}

/// A tick's motion after any rotation or thrust: gravity, move, and the
/// wrap at both edges.
#[inline(always)]
fn motion(p: &Physics, s: &mut State) {
    s.vy += -p.gravity;
    s.x += s.vx;
    s.y += s.vy;
    // Branches the CPU predicts, not selects: the wrap is rare, and as a
    // select its compares would lengthen the chain of additions to `x`
    // that carries from tick to tick.
    if s.x > p.width {
        std::hint::cold_path();
        s.x = 0.0;
    }
    if s.x < 0.0 {
        std::hint::cold_path();
        s.x = p.width;
    }
}

/// A flight together with its world's constants: the convenient form for
/// code that flies one lander at a time.
#[derive(Clone, Copy, Debug)]
pub struct Lander {
    pub physics: Physics,
    pub flight: Flight,
}

impl Lander {
    /// A lander at the start of a flight.
    pub fn new(env: &Env) -> Lander {
        Lander {
            physics: Physics::new(env),
            flight: Flight::start(env),
        }
    }

    /// A lander in `state` with `ticks` already flown, for tests and tools
    /// that start mid-flight.
    pub fn with_state(env: &Env, state: State, ticks: u32) -> Lander {
        Lander {
            physics: Physics::new(env),
            flight: Flight::at(state, ticks),
        }
    }

    pub fn state(&self) -> State {
        self.flight.state
    }

    pub fn ticks(&self) -> u32 {
        self.flight.ticks
    }

    pub fn touched_down(&self) -> bool {
        self.flight.touched_down()
    }

    pub fn ended(&self) -> bool {
        self.flight.ended(&self.physics)
    }

    pub fn run(&mut self, action: Action, ticks: u32) -> u32 {
        self.flight.run(&self.physics, action, ticks)
    }

    pub fn drift_to_end(&mut self) {
        self.flight.drift_to_end(&self.physics)
    }

    pub fn outcome(&self, env: &Env, n: u32) -> Outcome {
        self.flight.outcome(env, n)
    }
}

/// The lowest hull point's y offset from the centre.
fn lowest_offset(scale: f64, sin: f64, cos: f64) -> f64 {
    let mut low = f64::INFINITY;
    for y in hull_offsets_y(scale, sin, cos) {
        if y < low {
            low = y;
        }
    }
    low
}

/// The y offset of each hull point from the centre at a rotation given by
/// its sine and cosine, in the SPEC's exact expression.
pub fn hull_offsets_y(scale: f64, sin: f64, cos: f64) -> impl Iterator<Item = f64> {
    HULL.iter()
        .map(move |&(px, py)| scale * (-px * sin + py * cos))
}

/// The largest distance of a hull point from the centre, in model units:
/// the foot tips at `(±1.5, −1.2)`.
pub const HULL_RADIUS: f64 = 1.920_937_271_229_854_7;

/// Flies a genome from the start state to touchdown and scores it.
pub fn fly(env: &Env, genes: &[Gene]) -> Outcome {
    let p = Physics::new(env);
    let mut flight = Flight::start(env);
    flight.run_genes(&p, genes);
    let n = flight.ticks;
    flight.drift_to_end(&p);
    flight.outcome(env, n)
}

/// Flies like [`fly`], one tick at a time, showing `visit` the tick number,
/// the action and the state after each tick.
pub fn fly_traced(
    env: &Env,
    genes: &[Gene],
    mut visit: impl FnMut(u32, Action, &State),
) -> Outcome {
    let mut lander = Lander::new(env);
    let decoded = genes
        .iter()
        .flat_map(|g| std::iter::repeat_n(g.action, usize::from(g.duration)));
    let mut n = None;
    for (i, action) in decoded.map(Some).chain(std::iter::repeat(None)).enumerate() {
        if lander.ended() {
            break;
        }
        let action = action.unwrap_or_else(|| {
            n.get_or_insert(i as u32);
            Action::Drift
        });
        lander.run(action, 1);
        visit(lander.ticks(), action, &lander.flight.state);
    }
    lander.outcome(env, n.unwrap_or(lander.ticks()))
}

mod branch;

#[cfg(test)]
mod tests;

/// `sin_cos` and the hull's lowest point, remembered. Each thread keeps a
/// small direct-mapped table of the rotations it met, by their bits, so a
/// rotation met before costs a lookup instead of libm's `sincos` (about 5%
/// of a worker's time) and the 30-point minimum (a fifth of the guided
/// pass near the ground). The table holds only values computed for exactly
/// those bits (and, for the lowest point, that hull scale), so the results
/// are the same bit for bit.
mod trig {
    use std::cell::Cell;

    const SLOTS: usize = 256;

    #[derive(Clone, Copy)]
    struct Slot {
        bits: u64,
        sin: f64,
        cos: f64,
        /// The bits of the hull scale `low` was computed for, if it was.
        scale: Option<u64>,
        low: f64,
    }

    // Every slot starts as NaN's own answer, so no lookup can find a value
    // `sin_cos` would not give.
    const EMPTY: Slot = Slot {
        bits: 0x7ff8_0000_0000_0000,
        sin: f64::NAN,
        cos: f64::NAN,
        scale: None,
        low: f64::NAN,
    };

    thread_local! {
        // A `Cell` per slot, read and written whole: no borrow to count.
        static MEMO: [Cell<Slot>; SLOTS] = const { [const { Cell::new(EMPTY) }; SLOTS] };
    }

    /// The slot of `rot` as it is, and where it is kept. A slot that held
    /// another rotation comes back filled with `rot`'s `sin_cos`, which
    /// the caller then keeps.
    #[inline(always)]
    fn slot(memo: &[Cell<Slot>; SLOTS], rot: f64) -> (Slot, &Cell<Slot>, bool) {
        let bits = rot.to_bits();
        // Fibonacci hashing: the top bits of the product mix every bit in.
        let cell = &memo[(bits.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 56) as usize];
        let slot = cell.get();
        if slot.bits == bits {
            return (slot, cell, false);
        }
        let (sin, cos) = rot.sin_cos();
        let filled = Slot {
            bits,
            sin,
            cos,
            ..EMPTY
        };
        (filled, cell, true)
    }

    #[inline(always)]
    pub fn sin_cos(rot: f64) -> (f64, f64) {
        MEMO.with(|memo| {
            let (slot, cell, filled) = slot(memo, rot);
            if filled {
                cell.set(slot);
            }
            (slot.sin, slot.cos)
        })
    }

    /// [`super::lowest_offset`] at `rot`, remembered.
    // Out of line: inlined, the lookup's thread-local access and its rare
    // call to libm would crowd the flight loop's registers.
    #[inline(never)]
    pub fn lowest_at(scale: f64, rot: f64) -> f64 {
        MEMO.with(|memo| {
            // A slot just filled holds no lowest point (`scale` is `None`).
            let (mut slot, cell, _) = slot(memo, rot);
            if slot.scale != Some(scale.to_bits()) {
                slot.low = super::lowest_offset(scale, slot.sin, slot.cos);
                slot.scale = Some(scale.to_bits());
                cell.set(slot);
            }
            slot.low
        })
    }

    #[cfg(test)]
    mod tests {
        #[test]
        fn remembered_values_are_libms_bit_for_bit() {
            let mut rot = std::f64::consts::PI;
            for i in 0..10_000 {
                rot += if i % 3 == 0 { -0.1 } else { 0.1 };
                for r in [rot, -rot, f64::NAN, 0.0, -0.0] {
                    let (s, c) = super::sin_cos(r);
                    let (ls, lc) = r.sin_cos();
                    assert_eq!((s.to_bits(), c.to_bits()), (ls.to_bits(), lc.to_bits()));
                }
            }
        }

        #[test]
        fn remembered_lowest_points_are_computed_ones_bit_for_bit() {
            let mut rot = std::f64::consts::PI;
            for i in 0..10_000 {
                rot += if i % 3 == 0 { -0.1 } else { 0.1 };
                // Two scales in turn: a slot's lowest point is its scale's.
                for scale in [10.0, 7.5, f64::NAN] {
                    for r in [rot, -rot, f64::NAN, 0.0, -0.0] {
                        let (sin, cos) = r.sin_cos();
                        let want = crate::sim::lowest_offset(scale, sin, cos);
                        let got = super::lowest_at(scale, r);
                        assert_eq!(got.to_bits(), want.to_bits(), "scale {scale}, rot {r}");
                    }
                }
            }
        }
    }
}
