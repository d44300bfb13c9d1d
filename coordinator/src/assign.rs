//! Which free unit attacks which fire.
//!
//! Greedy on cost: repeatedly take the cheapest (unit, fire) pair among free units and
//! unattended fires. Cost is the straight-line travel time at the unit's top speed, a
//! lower bound of the real travel time. A unit that already works on a fire keeps it (the
//! caller passes only free units), so nobody is pulled off a fire it is spraying.

use firefleet_protocol::{FireId, Point2, UnitId};

/// A unit that could take a fire.
#[derive(Debug, Clone)]
pub struct Candidate {
    pub unit: UnitId,
    pub position: Point2,
    pub speed_m_s: f64,
}

/// A fire that needs a unit.
#[derive(Debug, Clone)]
pub struct Need {
    pub fire: FireId,
    pub position: Point2,
}

/// One decision: `unit` goes to `fire`, at `cost` seconds; `runner_up` is the next best
/// unit for the same fire and its cost, for the decision log.
#[derive(Debug, Clone, PartialEq)]
pub struct Pick {
    pub unit: UnitId,
    pub fire: FireId,
    pub cost_s: f64,
    pub runner_up: Option<(UnitId, f64)>,
}

/// Greedy minimum-cost pairing.
pub fn greedy(units: &[Candidate], needs: &[Need]) -> Vec<Pick> {
    let cost = |u: &Candidate, n: &Need| u.position.dist(n.position) / u.speed_m_s.max(0.1);
    let mut free_units: Vec<&Candidate> = units.iter().collect();
    let mut open: Vec<&Need> = needs.iter().collect();
    let mut picks = Vec::new();
    while !free_units.is_empty() && !open.is_empty() {
        let mut best: Option<(usize, usize, f64)> = None;
        for (i, u) in free_units.iter().enumerate() {
            for (j, n) in open.iter().enumerate() {
                let c = cost(u, n);
                // Ties break on unit id, so the outcome does not depend on input order.
                if best
                    .is_none_or(|(bi, _, bc)| c < bc || (c == bc && u.unit < free_units[bi].unit))
                {
                    best = Some((i, j, c));
                }
            }
        }
        let (i, j, c) = best.expect("both lists non-empty");
        let n = open.swap_remove(j);
        let u = free_units.swap_remove(i);
        let runner_up = free_units
            .iter()
            .map(|o| (o.unit.clone(), cost(o, n)))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        picks.push(Pick {
            unit: u.unit.clone(),
            fire: n.fire,
            cost_s: c,
            runner_up,
        });
    }
    picks
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cand(id: &str, x: f64) -> Candidate {
        Candidate {
            unit: UnitId::new(id).unwrap(),
            position: Point2::new(x, 0.0),
            speed_m_s: 1.0,
        }
    }

    #[test]
    fn nearest_free_unit_gets_each_fire() {
        let units = [cand("a", 0.0), cand("b", 40.0), cand("c", 100.0)];
        let needs = [
            Need {
                fire: FireId(1),
                position: Point2::new(50.0, 0.0),
            },
            Need {
                fire: FireId(2),
                position: Point2::new(5.0, 0.0),
            },
        ];
        let picks = greedy(&units, &needs);
        assert_eq!(picks.len(), 2);
        let of = |f: u32| picks.iter().find(|p| p.fire == FireId(f)).unwrap();
        assert_eq!(of(1).unit.as_str(), "b");
        assert_eq!(of(2).unit.as_str(), "a");
        assert_eq!(of(1).runner_up.as_ref().unwrap().0.as_str(), "c");
    }

    #[test]
    fn more_fires_than_units_leaves_the_farthest_unattended() {
        let picks = greedy(
            &[cand("a", 0.0)],
            &[
                Need {
                    fire: FireId(1),
                    position: Point2::new(90.0, 0.0),
                },
                Need {
                    fire: FireId(2),
                    position: Point2::new(10.0, 0.0),
                },
            ],
        );
        assert_eq!(picks.len(), 1);
        assert_eq!(picks[0].fire, FireId(2));
    }
}
