//! The guided pass's four branches, flown together.
//!
//! From one state the pass flies each of the four actions for the same
//! number of ticks (SPEC §4). Rotating and drifting never touch the
//! velocity, so those three branches move the centre along one and the same
//! path, bit for bit: the same additions on the same numbers, in the same
//! order. Only their rotations differ, and with them where each hull
//! touches down. [`Flight::branch`] therefore flies two paths instead of
//! four: the shared one, turning two rotations beside it, and thrust's own,
//! in one loop so that the two dependency chains overlap. Each branch stops
//! at its own touchdown, exactly where flying it alone stops.

use super::{motion, turned_left, turned_right, Flight, Physics};
use crate::{Action, State};

/// The branches that share the drifting path, by their index in
/// [`Action::ALL`].
const SHARED: [usize; 3] = [
    Action::RotateLeft as usize,
    Action::RotateRight as usize,
    Action::Drift as usize,
];
const LEFT: usize = Action::RotateLeft as usize;
const RIGHT: usize = Action::RotateRight as usize;
const THRUST: usize = Action::Thrust as usize;

/// The branches still flying, one bit per index in [`Action::ALL`]: a
/// mask rather than an array, so that the loop keeps it in a register.
type Alive = u8;

const ALL_ALIVE: Alive = 0b1111;

const fn bit(i: usize) -> Alive {
    1 << i
}

/// Tests the hulls of the branches on the shared path, `k` ticks into the
/// branch from `start` ticks; a branch down there stops. Returns the
/// branches still flying.
#[inline(never)]
fn land_shared(
    p: &Physics,
    lanes: &mut [Flight; 4],
    mut alive: Alive,
    flown: &mut [u32; 4],
    path: State,
    start: u32,
    k: u32,
) -> Alive {
    for i in SHARED {
        if alive & bit(i) != 0 && lanes[i].lands_at(p, &path, start + k) {
            alive &= !bit(i);
            flown[i] = k;
        }
    }
    alive
}

/// A thrust tick from `s`: [`Flight::thrust`] with the push precomputed,
/// then [`Flight::finish_tick`]'s motion.
#[inline(always)]
fn thrust_tick(p: &Physics, mut s: State, push_x: f64, push_y: f64) -> State {
    s.vx += push_x;
    s.vy += push_y;
    motion(p, &mut s);
    s
}

impl Flight {
    /// Writes into `lanes` the flights of the four actions from here, in
    /// [`Action::ALL`]'s order, each flown up to `ticks` ticks exactly as
    /// [`Flight::run`] flies it; returns the ticks the four flew in all.
    // The lanes are the caller's, not returned: returning them copied all
    // four (352 bytes) through memcpy once more per gene.
    #[inline(always)]
    pub fn branch(&self, p: &Physics, ticks: u32, lanes: &mut [Flight; 4]) -> u64 {
        *lanes = [*self; 4];
        if self.touched_down {
            return 0;
        }
        let ticks = ticks.min(p.max_ticks.saturating_sub(self.ticks));
        if ticks == 0 {
            return 0;
        }
        // The paths and rotations live in locals, not in `lanes`, so that
        // the chains of additions stay in registers; a lane is written
        // only where its hull is tested and at the end.
        lanes[THRUST].refresh_trig();
        let (push_x, push_y) = (p.thrust * lanes[THRUST].sin, p.thrust * lanes[THRUST].cos);
        let mut pushed = self.state;
        let mut path = self.state;
        let (mut rot_left, mut rot_right) = (self.state.rot, self.state.rot);
        let mut alive = ALL_ALIVE;
        let mut flown = [ticks; 4];
        // Aloft: while both centres are above `clear_y` no hull can touch
        // down, so every branch flies on and the loop makes no call. A
        // call would cost more than itself: every value the loop holds
        // would live in memory, and the chains of additions would wait on
        // stores and loads.
        let mut k = 1;
        loop {
            pushed = thrust_tick(p, pushed, push_x, push_y);
            rot_left = turned_left(p, rot_left);
            rot_right = turned_right(p, rot_right);
            motion(p, &mut path);
            if pushed.y < p.clear_y || path.y < p.clear_y || k == ticks {
                break;
            }
            k += 1;
        }
        // Near the ground: tick `k` is flown; test the hulls, then fly on,
        // testing every tick.
        loop {
            if alive & bit(THRUST) != 0
                && pushed.y < p.clear_y
                && lanes[THRUST].lands_at(p, &pushed, self.ticks + k)
            {
                alive &= !bit(THRUST);
                flown[THRUST] = k;
            }
            if path.y < p.clear_y {
                lanes[LEFT].state.rot = rot_left;
                lanes[RIGHT].state.rot = rot_right;
                alive = land_shared(p, lanes, alive, &mut flown, path, self.ticks, k);
            }
            if alive == 0 || k == ticks {
                break;
            }
            k += 1;
            if alive & bit(THRUST) != 0 {
                pushed = thrust_tick(p, pushed, push_x, push_y);
            }
            if alive & bit(LEFT) != 0 {
                rot_left = turned_left(p, rot_left);
            }
            if alive & bit(RIGHT) != 0 {
                rot_right = turned_right(p, rot_right);
            }
            motion(p, &mut path);
        }
        lanes[LEFT].state.rot = rot_left;
        lanes[RIGHT].state.rot = rot_right;
        if alive & bit(THRUST) != 0 {
            lanes[THRUST].move_to(pushed, self.ticks + ticks);
        }
        for i in SHARED {
            if alive & bit(i) != 0 {
                lanes[i].move_to(path, self.ticks + ticks);
            }
        }
        flown.iter().map(|&f| u64::from(f)).sum()
    }

    /// Says whether this branch's hull is down with its centre at `path`
    /// after `ticks` ticks, keeping its own rotation; if it is, the branch
    /// stops there.
    #[inline(always)]
    fn lands_at(&mut self, p: &Physics, path: &State, ticks: u32) -> bool {
        if !self.hull_below_at(p, path.y) {
            return false;
        }
        self.move_to(*path, ticks);
        self.touched_down = true;
        true
    }

    /// The hull test at height `y`, this branch's own rotation.
    // Out of line: its caller's loop then keeps only the paths in
    // registers, not every lane's cached trigonometry and hull bound. It
    // takes the height alone, in a register: loading the caller's freshly
    // stored path whole would stall on store forwarding.
    #[inline(never)]
    fn hull_below_at(&mut self, p: &Physics, y: f64) -> bool {
        self.hull_below(p, y)
    }

    /// `path`'s position and velocity, with this branch's own rotation.
    #[inline(always)]
    fn move_to(&mut self, path: State, ticks: u32) {
        let rot = self.state.rot;
        self.state = path;
        self.state.rot = rot;
        self.ticks = ticks;
    }
}

impl Flight {
    /// [`Flight::branch`] as four [`Flight::run`]s one after another: the
    /// oracle that `branch` must equal in every bit, and the baseline of
    /// the benches.
    pub fn branch_one_by_one(&self, p: &Physics, ticks: u32, lanes: &mut [Flight; 4]) -> u64 {
        *lanes = [*self; 4];
        let mut flown = 0;
        for (lane, action) in lanes.iter_mut().zip(Action::ALL) {
            flown += u64::from(lane.run(p, action, ticks));
        }
        flown
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_env;
    use proptest::prelude::*;
    use std::f64::consts::{PI, TAU};

    /// [`Flight::branch`]'s lanes and ticks flown, returned.
    fn branched(from: &Flight, p: &Physics, ticks: u32) -> ([Flight; 4], u64) {
        let mut lanes = [*from; 4];
        let flown = from.branch(p, ticks, &mut lanes);
        (lanes, flown)
    }

    /// [`Flight::branch_one_by_one`]'s lanes and ticks flown, returned.
    fn one_by_one(from: &Flight, p: &Physics, ticks: u32) -> ([Flight; 4], u64) {
        let mut lanes = [*from; 4];
        let flown = from.branch_one_by_one(p, ticks, &mut lanes);
        (lanes, flown)
    }

    /// Every lane of `branch` equals the same lane flown alone, in every
    /// bit, and so do the ticks flown.
    fn same_as_one_by_one(
        state: State,
        ticks_so_far: u32,
        ticks: u32,
    ) -> Result<(), TestCaseError> {
        let e = test_env(200.0, 100.0);
        let p = Physics::new(&e);
        let from = Flight::at(state, ticks_so_far);
        let (fast, flown) = branched(&from, &p, ticks);
        let (slow, flown_alone) = one_by_one(&from, &p, ticks);
        for (a, (f, s)) in Action::ALL.into_iter().zip(fast.iter().zip(&slow)) {
            prop_assert_eq!(f.state, s.state, "{:?}", a);
            prop_assert_eq!(f.ticks, s.ticks, "{:?}", a);
            prop_assert_eq!(f.touched_down(), s.touched_down(), "{:?}", a);
        }
        prop_assert_eq!(flown, flown_alone);
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(3000))]

        #[test]
        fn branches_flown_together_equal_branches_flown_alone(
            x in 0.0f64..400.0, y in 40.0f64..300.0,
            vx in -3.0f64..3.0, vy in -3.0f64..3.0, rot in -PI..TAU,
            ticks in 0u32..=40,
        ) {
            same_as_one_by_one(State { x, y, vx, vy, rot }, 0, ticks)?;
        }

        /// Low over the ground, where the branches touch down on different
        /// ticks, and spinning, where the hull bound works hardest.
        #[test]
        fn branches_touching_down_apart_equal_branches_flown_alone(
            x in 0.0f64..400.0, y in 52.0f64..80.0,
            vx in -0.5f64..0.5, vy in -1.0f64..0.5, rot in -PI..TAU,
            ticks in 1u32..=30,
        ) {
            same_as_one_by_one(State { x, y, vx, vy, rot }, 0, ticks)?;
        }

        /// Near the tick guard, every branch stops at it.
        #[test]
        fn branches_stop_at_the_tick_guard_as_alone(
            y in 100.0f64..300.0, rot in -PI..TAU, left in 0u32..10, ticks in 0u32..=30,
        ) {
            let max = test_env(0.0, 0.0).world.max_ticks;
            let state = State { x: 200.0, y, vx: 0.3, vy: 0.0, rot };
            same_as_one_by_one(state, max - left, ticks)?;
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]

        /// From a lane an earlier branch left, its caches warm, as the
        /// guided pass branches gene after gene.
        #[test]
        fn branching_again_from_a_branch_equals_flying_alone(
            x in 0.0f64..400.0, y in 52.0f64..120.0,
            vx in -0.5f64..0.5, vy in -1.0f64..0.5, rot in -PI..TAU,
            first in 1u32..=20, lane in 0usize..4, then in 1u32..=20,
        ) {
            let e = test_env(200.0, 100.0);
            let p = Physics::new(&e);
            let (lanes, _) = branched(&Flight::at(State { x, y, vx, vy, rot }, 0), &p, first);
            let from = lanes[lane];
            let (fast, flown) = branched(&from, &p, then);
            let (slow, flown_alone) = one_by_one(&from, &p, then);
            for (f, s) in fast.iter().zip(&slow) {
                prop_assert_eq!((f.state, f.ticks, f.touched_down()), (s.state, s.ticks, s.touched_down()));
            }
            prop_assert_eq!(flown, flown_alone);
        }
    }

    #[test]
    fn a_flight_that_touched_down_branches_nowhere() {
        let e = test_env(200.0, 100.0);
        let p = Physics::new(&e);
        let mut down = Flight::start(&e);
        down.drift_to_end(&p);
        assert!(down.touched_down());
        let (lanes, flown) = branched(&down, &p, 30);
        assert_eq!(flown, 0);
        assert!(lanes
            .iter()
            .all(|l| l.state == down.state && l.ticks == down.ticks));
    }
}
