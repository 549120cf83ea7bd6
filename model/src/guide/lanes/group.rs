//! The walks under way, one a lane: their states as arrays, a gene's four
//! branches flown for every lane in vector registers, R scored for every
//! lane at once, and the choices made lane by lane.
//!
//! Near the ground every branch's hull is tested every tick, as
//! [`Flight::branch`] tests it: a bound from the lowest hull point
//! remembered for the branch (`HullMemo`'s) rules touchdown out for most
//! lanes at once, in the tick loop; only where it cannot is the lowest
//! point looked up, out of the loop, lane by lane.

use super::vector::{M, V};
use super::{Done, Walk, LANES};
use crate::guide::walk_on;
use crate::score::{is_safe, reinforcement};
use crate::sim::{trig, Flight, Physics};
use crate::{Action, Env, Gene, GuideParams, State};
use rand::Rng;
use std::f64::consts::{PI, TAU};

/// The four branches by their index in [`Action::ALL`].
const LEFT: usize = Action::RotateLeft as usize;
const RIGHT: usize = Action::RotateRight as usize;
const THRUST: usize = Action::Thrust as usize;
const DRIFT: usize = Action::Drift as usize;

/// A lane's walk: its genome, where it is in it, and what the lane's
/// arrays do not hold.
struct Lane<G> {
    walk: Walk<G>,
    /// The gene to fly next.
    gene: usize,
    simulated: u64,
}

/// A state a lane, as plain arrays.
#[derive(Clone, Copy, Default)]
struct States {
    x: [f64; LANES],
    y: [f64; LANES],
    vx: [f64; LANES],
    vy: [f64; LANES],
    rot: [f64; LANES],
}

impl States {
    fn get(&self, l: usize) -> State {
        State {
            x: self.x[l],
            y: self.y[l],
            vx: self.vx[l],
            vy: self.vy[l],
            rot: self.rot[l],
        }
    }

    fn set(&mut self, l: usize, s: State) {
        self.x[l] = s.x;
        self.y[l] = s.y;
        self.vx[l] = s.vx;
        self.vy[l] = s.vy;
        self.rot[l] = s.rot;
    }

    #[inline(always)]
    fn load(&self) -> Lanes {
        Lanes {
            x: V::from_array(self.x),
            y: V::from_array(self.y),
            vx: V::from_array(self.vx),
            vy: V::from_array(self.vy),
            rot: V::from_array(self.rot),
        }
    }
}

/// A state a lane, in vector registers.
#[derive(Clone, Copy)]
struct Lanes {
    x: V,
    y: V,
    vx: V,
    vy: V,
    rot: V,
}

impl Lanes {
    #[inline(always)]
    fn store(self) -> States {
        States {
            x: self.x.to_array(),
            y: self.y.to_array(),
            vx: self.vx.to_array(),
            vy: self.vy.to_array(),
            rot: self.rot.to_array(),
        }
    }
}

/// The two paths of a gene's branches (see `sim/branch.rs`) as they stand:
/// thrust's, and the one the other three share, each of those turning its
/// own rotation beside it.
#[derive(Clone, Copy)]
struct Paths {
    pushed: Lanes,
    shared: Lanes,
    left: V,
    right: V,
}

impl Paths {
    /// One tick in the lanes of `on`, short of the wraps: thrust's
    /// `Flight::thrust` and `motion`, the shared path's `motion`, and the
    /// two turns.
    #[inline(always)]
    fn advance(&mut self, on: M, f: &Forces) {
        let (pushed, shared) = (&mut self.pushed, &mut self.shared);
        let vx = pushed.vx + f.push_x;
        let vy = pushed.vy + f.push_y + f.gravity;
        pushed.x = on.select(pushed.x + vx, pushed.x);
        pushed.y = on.select(pushed.y + vy, pushed.y);
        pushed.vx = on.select(vx, pushed.vx);
        pushed.vy = on.select(vy, pushed.vy);
        let vy = shared.vy + f.gravity;
        shared.x = on.select(shared.x + shared.vx, shared.x);
        shared.y = on.select(shared.y + vy, shared.y);
        shared.vy = on.select(vy, shared.vy);
        self.left = on.select(self.left - f.turn, self.left);
        self.right = on.select(self.right + f.turn, self.right);
    }

    /// The lanes where a path is past an edge or a turn past its wrap.
    #[inline(always)]
    fn beyond(&self, width: V) -> M {
        let zero = V::splat(0.0);
        let (pushed, shared) = (self.pushed.x, self.shared.x);
        pushed.gt(width)
            | pushed.lt(zero)
            | shared.gt(width)
            | shared.lt(zero)
            | self.left.lt(V::splat(-PI))
            | self.right.gt(V::splat(TAU))
    }

    /// `motion`'s wraps and the turns' in the lanes of `on`, as the scalar
    /// flight makes them.
    #[inline(always)]
    fn wrap(&mut self, width: V, on: M) {
        self.pushed.x = on.select(wrap(width, self.pushed.x), self.pushed.x);
        self.shared.x = on.select(wrap(width, self.shared.x), self.shared.x);
        self.left = on.select(wrap_left(self.left), self.left);
        self.right = on.select(wrap_right(self.right), self.right);
    }

    /// Each branch's state where its path stands, by branch.
    #[inline(always)]
    fn ends(&self, rot: V) -> [Lanes; 4] {
        let mut ends = [self.shared; 4];
        ends[THRUST] = self.pushed;
        ends[LEFT].rot = self.left;
        ends[RIGHT].rot = self.right;
        ends[THRUST].rot = rot;
        ends[DRIFT].rot = rot;
        ends
    }
}

/// What moves the paths each tick.
struct Forces {
    /// Thrust's push along each lane's rotation.
    push_x: V,
    push_y: V,
    /// Gravity's pull, as `motion` adds it: `-gravity`.
    gravity: V,
    turn: V,
}

/// The terms of R that a path's branches share: all but the rotation's.
#[derive(Clone, Copy)]
struct Terms {
    dis_fit: V,
    air_time: V,
}

/// A gene's four branches from every lane's state, by their index in
/// [`Action::ALL`].
struct Branches {
    at: [States; 4],
    /// R of each (SPEC eq. 3).
    r: [[f64; LANES]; 4],
    /// Ticks each flew: the gene's, or fewer where it touched down.
    flown: [[u32; LANES]; 4],
    down: [M; 4],
}

/// Where a gene's branches touched down, while the gene is flown.
struct Stops {
    down: [M; 4],
    flown: [[u32; LANES]; 4],
    /// Where a branch down stopped (elsewhere, nothing of use).
    at: [States; 4],
}

/// The hull's lowest point at one rotation a lane and branch, remembered
/// as `HullMemo` remembers it: near the ground it bounds the lowest point
/// at nearby rotations. Any lane's may serve any walk, since every lane
/// flies the same hull.
struct Hulls {
    rot: [[f64; LANES]; 4],
    low: [[f64; LANES]; 4],
}

/// The walks under way, one a lane.
pub(super) struct Group<'p, G> {
    p: Physics,
    /// The world and scoring every walk shares; each lane's pad is its own.
    env: Env,
    params: &'p GuideParams,
    lanes: [Option<Lane<G>>; LANES],
    at: States,
    ticks: [u32; LANES],
    pad_x: [f64; LANES],
    /// Each lane's `sin` and `cos` of `trig_rot`, for thrust's push.
    trig_rot: [f64; LANES],
    sin: [f64; LANES],
    cos: [f64; LANES],
    hulls: Hulls,
}

impl<'p, G: AsMut<[Gene]>> Group<'p, G> {
    /// [`super::guide_lanes`]'s work; only for code compiled for AVX-512
    /// on a CPU that has it (see `vector`).
    #[inline(always)]
    pub(super) fn walk_all(
        params: &'p GuideParams,
        mut walks: impl Iterator<Item = Walk<G>>,
        done: &mut Done<'_, G>,
    ) {
        let Some(first) = walks.next() else {
            return;
        };
        let mut group = Group {
            p: Physics::new(&first.env),
            env: first.env,
            params,
            lanes: Default::default(),
            at: States::default(),
            ticks: [0; LANES],
            pad_x: [0.0; LANES],
            trig_rot: [f64::NAN; LANES],
            sin: [0.0; LANES],
            cos: [0.0; LANES],
            hulls: Hulls {
                // Nothing remembered: NaN fails every bound.
                rot: [[f64::NAN; LANES]; 4],
                low: [[0.0; LANES]; 4],
            },
        };
        let mut walks = std::iter::once(first).chain(walks);
        loop {
            let ticks = group.fill(&mut walks, done);
            if group.lanes.iter().all(Option::is_none) {
                return;
            }
            group.step(&ticks, done);
        }
    }

    /// Puts the next walks into the empty lanes, and returns each lane's
    /// ticks for its next gene, cut at the tick guard (none for an empty
    /// lane). A walk in another world goes on alone.
    fn fill(
        &mut self,
        walks: &mut impl Iterator<Item = Walk<G>>,
        done: &mut Done<'_, G>,
    ) -> [u32; LANES] {
        let mut ticks = [0; LANES];
        for (l, ticks) in ticks.iter_mut().enumerate() {
            while self.lanes[l].is_none() {
                let Some(walk) = walks.next() else {
                    break;
                };
                let start = Flight::start(&walk.env);
                if walk.env.world != self.env.world || walk.env.scoring != self.env.scoring {
                    alone(self.params, walk, 0, start, 0, done);
                    continue;
                }
                self.at.set(l, start.state);
                self.ticks[l] = 0;
                self.pad_x[l] = walk.env.pad_x;
                self.lanes[l] = Some(Lane {
                    walk,
                    gene: 0,
                    simulated: 0,
                });
            }
            if let Some(lane) = &mut self.lanes[l] {
                let gene = lane.walk.genes.as_mut()[lane.gene];
                *ticks = u32::from(gene.duration).min(self.p.max_ticks - self.ticks[l]);
            }
        }
        ticks
    }

    /// Flies every lane's next gene of `ticks` four ways, chooses, and
    /// ends the walks that are over.
    #[inline(always)]
    fn step(&mut self, ticks: &[u32; LANES], done: &mut Done<'_, G>) {
        let p = self.p;
        let (mut push_x, mut push_y) = ([0.0; LANES], [0.0; LANES]);
        for l in 0..LANES {
            if ticks[l] > 0 {
                let rot = self.at.rot[l];
                if rot.to_bits() != self.trig_rot[l].to_bits() {
                    (self.sin[l], self.cos[l]) = trig::sin_cos(rot);
                    self.trig_rot[l] = rot;
                }
                (push_x[l], push_y[l]) = (p.thrust * self.sin[l], p.thrust * self.cos[l]);
            }
        }
        let branches = self.branch(ticks, V::from_array(push_x), V::from_array(push_y));
        for l in 0..LANES {
            if self.lanes[l].is_some() {
                self.choose(l, &branches, done);
            }
        }
    }

    /// Every lane's four branches, flown for its `ticks`, with R of each.
    #[inline(always)]
    fn branch(&mut self, ticks: &[u32; LANES], push_x: V, push_y: V) -> Branches {
        let p = self.p;
        let at = self.at.load();
        let mut paths = Paths {
            pushed: at,
            shared: at,
            left: at.rot,
            right: at.rot,
        };
        let forces = Forces {
            push_x,
            push_y,
            gravity: V::splat(-p.gravity),
            turn: V::splat(p.rotation_step),
        };
        // Tick counts as numbers, exact up to 2^53, so that a lane's tick
        // is compared with its gene's in one instruction.
        let (ticks_v, one, width) = (
            V::from_array(ticks.map(f64::from)),
            V::splat(1.0),
            V::splat(p.width),
        );
        let mut longest = 0;
        for &t in ticks {
            longest = longest.max(t);
        }
        let mut stops = Stops {
            down: [M::default(); 4],
            flown: [*ticks; 4],
            at: [States::default(); 4],
        };
        let mut alive = [one.le(ticks_v); 4];
        let clear_y = V::splat(p.clear_y);
        let mut k = one;
        for tick in 1..=longest {
            let on = k.le(ticks_v);
            k = k + one;
            paths.advance(on, &forces);
            // The wraps as branches the CPU predicts: as selects they
            // would lengthen each tick's chain of additions.
            let beyond = on & paths.beyond(width);
            if beyond.any() {
                paths.wrap(width, beyond);
            }
            let low = (alive[THRUST] & paths.pushed.y.lt(clear_y))
                | ((alive[LEFT] | alive[RIGHT] | alive[DRIFT]) & paths.shared.y.lt(clear_y));
            if (on & low).any() {
                let ends = paths.ends(at.rot);
                let mut testing = [M::default(); 4];
                for i in 0..4 {
                    testing[i] = self.may_touch(i, on & alive[i], &ends[i]);
                }
                if (testing[0] | testing[1] | testing[2] | testing[3]).any() {
                    // SAFETY: `branch` runs only inside `lanes_avx512`, on
                    // a CPU with AVX-512.
                    unsafe { self.land(tick, &testing, &ends, &mut alive, &mut stops) };
                }
            }
        }
        // R's terms of a path are worked once for the branches on it, and
        // the rotation's once for thrust and drift, which keep the gene's.
        let ends = paths.ends(at.rot);
        let pushed = self.terms(&paths.pushed);
        let shared = self.terms(&paths.shared);
        let kept = rot_fits(at.rot);
        let rot_fit = [rot_fits(paths.left), rot_fits(paths.right), kept, kept];
        let mut b = Branches {
            at: [States::default(); 4],
            r: [[0.0; LANES]; 4],
            flown: stops.flown,
            down: stops.down,
        };
        for i in 0..4 {
            let terms = if i == THRUST { pushed } else { shared };
            b.r[i] = self.reinforcement(&terms, rot_fit[i]).to_array();
            b.at[i] = ends[i].store();
            // A branch that stopped short of its path ends where it
            // stopped, scored alone (few do).
            for l in 0..LANES {
                if stops.down[i].get(l) {
                    let s = stops.at[i].get(l);
                    b.at[i].set(l, s);
                    let env = Env {
                        pad_x: self.pad_x[l],
                        ..self.env
                    };
                    b.r[i][l] = reinforcement(&env, self.params, &s);
                }
            }
        }
        b
    }

    /// The lanes of `testing` whose branch `i`, standing at `end`, the
    /// remembered lowest point cannot keep off the ground: `HullMemo::below`
    /// short of its lookup. Where the rotation is the one remembered, the
    /// test is exact and these lanes are down.
    #[inline(always)]
    fn may_touch(&self, i: usize, testing: M, end: &Lanes) -> M {
        if !testing.any() {
            return testing;
        }
        let p = &self.p;
        let ground = V::splat(p.ground_y);
        let (rot, low) = (
            V::from_array(self.hulls.rot[i]),
            V::from_array(self.hulls.low[i]),
        );
        let same = end.rot.eq(rot);
        let bound = low - V::splat(p.reach) * (end.rot - rot).abs() - V::splat(1e-9);
        let ruled_out = !same & (end.y + bound).ge(ground);
        let down = same & (end.y + low).lt(ground);
        testing & end.y.lt(V::splat(p.clear_y)) & (down | (!same & !ruled_out))
    }

    /// Tests the hulls of the branches in the lanes of `testing`, standing
    /// at `ends`, `tick` ticks into the gene, looking up the lowest point
    /// where it is not remembered: `HullMemo::below`'s exact part. A branch
    /// down stops there, and is no longer `alive`.
    ///
    /// # Safety
    ///
    /// Only on a CPU with AVX-512. Out of line, so that the tick loop
    /// keeps its paths in registers.
    #[target_feature(enable = "avx512f")]
    #[inline(never)]
    unsafe fn land(
        &mut self,
        tick: u32,
        testing: &[M; 4],
        ends: &[Lanes; 4],
        alive: &mut [M; 4],
        stops: &mut Stops,
    ) {
        let p = self.p;
        for i in 0..4 {
            if !testing[i].any() {
                continue;
            }
            let (y, rot) = (ends[i].y.to_array(), ends[i].rot.to_array());
            let mut fell = M::default();
            for l in 0..LANES {
                if !testing[i].get(l) {
                    continue;
                }
                if rot[l] != self.hulls.rot[i][l] {
                    self.hulls.low[i][l] = trig::lowest_at(p.hull_scale, rot[l]);
                    self.hulls.rot[i][l] = rot[l];
                }
                if y[l] + self.hulls.low[i][l] < p.ground_y {
                    fell.set(l);
                }
            }
            if fell.any() {
                alive[i] = alive[i] & !fell;
                stops.down[i] = stops.down[i] | fell;
                let at = ends[i].store();
                for l in 0..LANES {
                    if fell.get(l) {
                        stops.at[i].set(l, at.get(l));
                        stops.flown[i][l] = tick;
                    }
                }
            }
        }
    }

    /// The terms of R (SPEC eq. 3) that depend on the centre and the
    /// velocity alone: `score::reinforcement`'s operations, in its order.
    #[inline(always)]
    fn terms(&self, s: &Lanes) -> Terms {
        let (w, g) = (&self.env.world, self.params);
        let one = V::splat(1.0);
        let alt = s.y - V::splat(w.ground_y);
        let dis_fit_x = V::splat(w.width) - (V::from_array(self.pad_x) - s.x).abs();
        let dis_fit_y = V::splat(w.height) - alt.abs();
        let dis_fit = (dis_fit_x * dis_fit_x + dis_fit_y * dis_fit_y / V::splat(g.w_y)).sqrt();
        let speed = (s.vx * s.vx + s.vy * s.vy).sqrt();
        let slowed = alt
            .lt(V::splat(g.h2))
            .select(V::splat(g.w_t) * speed + one, speed + one);
        Terms {
            dis_fit: alt
                .lt(V::splat(g.h1))
                .select(dis_fit * V::splat(g.r), dis_fit),
            air_time: one / slowed,
        }
    }

    /// R from its terms and `score::rot_fit` of the rotation, as
    /// `score::reinforcement` adds them.
    #[inline(always)]
    fn reinforcement(&self, t: &Terms, rot_fit: V) -> V {
        let sc = &self.env.scoring;
        V::splat(sc.w1) * t.dis_fit + V::splat(sc.w2) * rot_fit + V::splat(sc.w3) * t.air_time
    }

    /// Lane `l`'s choice for its gene, as `guide_in_place` makes it; moves
    /// the lane on, and ends its walk if it is over.
    #[inline(never)]
    fn choose(&mut self, l: usize, b: &Branches, done: &mut Done<'_, G>) {
        let Some(lane) = &mut self.lanes[l] else {
            return;
        };
        let mut best = Action::RotateLeft;
        let mut best_r = f64::NEG_INFINITY;
        for action in Action::ALL {
            let r = b.r[usize::from(action.index())][l];
            if r > best_r {
                best = action;
                best_r = r;
            }
        }
        let i = usize::from(best.index());
        let env = Env {
            pad_x: self.pad_x[l],
            ..self.env
        };
        let safe = b.down[i].get(l) && is_safe(&env, &b.at[i].get(l));
        let genes = lane.walk.genes.as_mut();
        let gene = &mut genes[lane.gene];
        if safe || (best != gene.action && lane.walk.rng.random::<f64>() >= self.params.epsilon) {
            gene.action = best;
        }
        let chosen = usize::from(gene.action.index());
        lane.simulated += b.flown.iter().map(|f| u64::from(f[l])).sum::<u64>();
        lane.gene += 1;
        let s = b.at[chosen].get(l);
        let down = b.down[chosen].get(l);
        self.at.set(l, s);
        self.ticks[l] += b.flown[chosen][l];
        if down || self.ticks[l] >= self.p.max_ticks || lane.gene == genes.len() {
            if let Some(lane) = self.lanes[l].take() {
                done(
                    lane.walk,
                    Flight::ended_at(s, self.ticks[l], down),
                    lane.simulated,
                );
            }
        }
    }
}

/// A walk on its own from gene `gene`, where it stands at `flight` with
/// `simulated` ticks simulated.
fn alone<G: AsMut<[Gene]>>(
    params: &GuideParams,
    mut walk: Walk<G>,
    gene: usize,
    flight: Flight,
    simulated: u64,
    done: &mut Done<'_, G>,
) {
    let genes = &mut walk.genes.as_mut()[gene..];
    let (flight, more) = walk_on(&walk.env, params, genes, flight, &mut walk.rng);
    done(walk, flight, simulated + more);
}

/// `score::rot_fit` a lane.
#[inline(always)]
fn rot_fits(rot: V) -> V {
    let one = V::splat(1.0);
    one / (rot.abs() + one)
}

/// `motion`'s wrap at both edges, as selects.
#[inline(always)]
fn wrap(width: V, x: V) -> V {
    let x = x.gt(width).select(V::splat(0.0), x);
    x.lt(V::splat(0.0)).select(width, x)
}

/// `turned_left`'s wrap, as a select.
#[inline(always)]
fn wrap_left(rot: V) -> V {
    rot.lt(V::splat(-PI)).select(rot + V::splat(TAU), rot)
}

/// `turned_right`'s wrap, as a select.
#[inline(always)]
fn wrap_right(rot: V) -> V {
    rot.gt(V::splat(TAU)).select(rot - V::splat(TAU), rot)
}
