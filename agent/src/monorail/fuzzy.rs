//! A small Mamdani fuzzy inference engine.
//!
//! Linguistic variables, their sets and the rules are data: a system is built once from
//! [`Variable`]s and rule texts such as
//! `if distance is high and temperature is low then vehicle is moving, valve is closed`,
//! and then evaluated many times without allocating. Inference is the classic Mamdani
//! scheme (as in MATLAB's Fuzzy Logic Toolbox, which the ROBOGAT paper used):
//!
//! - AND is `min`; a rule fires with the least membership of its antecedent clauses;
//! - implication clips each consequent set at the rule's strength (`min`);
//! - aggregation takes the pointwise `max` over every rule's clipped sets;
//! - defuzzification is the centroid of the aggregate.
//!
//! The centroid is computed on [`RESOLUTION`] evenly spaced points of the output's range,
//! with the sets' memberships tabulated at build time (trapezoidal rule): one inference is then a few hundred
//! `min`/`max` operations, well inside a 1 kHz control step. When no rule with a consequent
//! on an output fires, that output is the middle of its range (MATLAB's convention).
//!
//! Not here: OR and NOT in antecedents, rule weights, Sugeno systems; the ROBOGAT rules do
//! not need them.

use std::fmt;

/// Points on which output sets are sampled for the centroid.
pub const RESOLUTION: usize = 101;

/// A membership function. Shoulders are trapezoids whose outer corners lie at infinity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Set {
    /// Zero outside `[a, c]`, one at `b`, linear between.
    Triangle { a: f64, b: f64, c: f64 },
    /// Zero outside `[a, d]`, one on `[b, c]`, linear between. `a = b = -inf` or
    /// `c = d = inf` make a shoulder.
    Trapezoid { a: f64, b: f64, c: f64, d: f64 },
}

impl Set {
    /// Full membership at or below `full`, none at or above `zero`.
    pub fn left_shoulder(full: f64, zero: f64) -> Self {
        Set::Trapezoid {
            a: f64::NEG_INFINITY,
            b: f64::NEG_INFINITY,
            c: full,
            d: zero,
        }
    }

    /// No membership at or below `zero`, full at or above `full`.
    pub fn right_shoulder(zero: f64, full: f64) -> Self {
        Set::Trapezoid {
            a: zero,
            b: full,
            c: f64::INFINITY,
            d: f64::INFINITY,
        }
    }

    /// Degree of membership of `x`, in [0, 1].
    pub fn degree(&self, x: f64) -> f64 {
        let (a, b, c, d) = match *self {
            Set::Triangle { a, b, c } => (a, b, b, c),
            Set::Trapezoid { a, b, c, d } => (a, b, c, d),
        };
        if x < a || x > d {
            0.0
        } else if x < b {
            (x - a) / (b - a)
        } else if x <= c {
            1.0
        } else {
            (d - x) / (d - c)
        }
    }

    fn is_ordered(&self) -> bool {
        let ok = |v: &[f64]| v.windows(2).all(|w| w[0] <= w[1]) && !v.iter().any(|x| x.is_nan());
        match *self {
            Set::Triangle { a, b, c } => ok(&[a, b, c]) && a < c,
            Set::Trapezoid { a, b, c, d } => ok(&[a, b, c, d]) && a < d,
        }
    }
}

/// A linguistic variable: a name, the range of its crisp values and its named sets.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    pub name: String,
    pub range: (f64, f64),
    pub terms: Vec<(String, Set)>,
}

impl Variable {
    pub fn new(name: &str, range: (f64, f64), terms: &[(&str, Set)]) -> Self {
        Self {
            name: name.to_owned(),
            range,
            terms: terms.iter().map(|(n, s)| ((*n).to_owned(), *s)).collect(),
        }
    }

    fn term(&self, name: &str) -> Option<usize> {
        self.terms.iter().position(|(n, _)| n == name)
    }
}

/// Why a fuzzy system could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FuzzyError {
    #[error("variable '{0}': the range must be finite and increasing")]
    Range(String),
    #[error("variable '{variable}': set '{term}' has unordered or NaN corners")]
    Set { variable: String, term: String },
    #[error("variable '{0}' is declared twice")]
    Duplicate(String),
    #[error("rule {rule} ('{text}'): {reason}")]
    Rule {
        rule: usize,
        text: String,
        reason: String,
    },
}

/// One parsed rule: antecedent clauses over inputs, consequents over outputs, as indices.
#[derive(Debug, Clone, PartialEq)]
struct Rule {
    when: Vec<(usize, usize)>,
    then: Vec<(usize, usize)>,
}

/// A built Mamdani system.
#[derive(Debug, Clone)]
pub struct Mamdani {
    inputs: Vec<Variable>,
    outputs: Vec<Variable>,
    rules: Vec<Rule>,
    /// Per output, per term: the set's membership at each of the [`RESOLUTION`] points.
    tables: Vec<Vec<[f64; RESOLUTION]>>,
}

/// Buffers one inference works in, so that [`Mamdani::infer`] does not allocate.
#[derive(Debug, Clone)]
pub struct Scratch {
    /// Per output, per term: the strongest rule concluding it.
    strength: Vec<Vec<f64>>,
}

impl Mamdani {
    /// Build a system; every rule is parsed against the variables' names.
    pub fn new(
        inputs: Vec<Variable>,
        outputs: Vec<Variable>,
        rules: &[&str],
    ) -> Result<Self, FuzzyError> {
        let mut names = std::collections::HashSet::new();
        for v in inputs.iter().chain(&outputs) {
            if !names.insert(v.name.as_str()) {
                return Err(FuzzyError::Duplicate(v.name.clone()));
            }
            let (lo, hi) = v.range;
            if !(lo.is_finite() && hi.is_finite() && lo < hi) {
                return Err(FuzzyError::Range(v.name.clone()));
            }
            if let Some((term, _)) = v.terms.iter().find(|(_, s)| !s.is_ordered()) {
                return Err(FuzzyError::Set {
                    variable: v.name.clone(),
                    term: term.clone(),
                });
            }
        }
        let rules = rules
            .iter()
            .enumerate()
            .map(|(i, text)| {
                parse_rule(text, &inputs, &outputs).map_err(|reason| FuzzyError::Rule {
                    rule: i + 1,
                    text: (*text).to_owned(),
                    reason,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let tables = outputs
            .iter()
            .map(|v| {
                let (lo, hi) = v.range;
                v.terms
                    .iter()
                    .map(|(_, set)| {
                        std::array::from_fn(|k| {
                            set.degree(lo + (hi - lo) * k as f64 / (RESOLUTION - 1) as f64)
                        })
                    })
                    .collect()
            })
            .collect();
        Ok(Self {
            inputs,
            outputs,
            rules,
            tables,
        })
    }

    pub fn inputs(&self) -> &[Variable] {
        &self.inputs
    }

    pub fn outputs(&self) -> &[Variable] {
        &self.outputs
    }

    /// Buffers for [`Mamdani::infer`].
    pub fn scratch(&self) -> Scratch {
        Scratch {
            strength: self
                .outputs
                .iter()
                .map(|v| vec![0.0; v.terms.len()])
                .collect(),
        }
    }

    /// Crisp outputs for crisp inputs, in declaration order. Inputs outside their range
    /// are clamped to it (a sensor reading past the designed range is as extreme as the
    /// range's end).
    ///
    /// # Panics
    /// If `x` or `out` do not have one value per input or output.
    pub fn infer(&self, x: &[f64], scratch: &mut Scratch, out: &mut [f64]) {
        assert_eq!(x.len(), self.inputs.len(), "one value per input");
        assert_eq!(out.len(), self.outputs.len(), "one value per output");
        for s in &mut scratch.strength {
            s.fill(0.0);
        }
        for rule in &self.rules {
            let w = rule
                .when
                .iter()
                .map(|&(v, t)| {
                    let var = &self.inputs[v];
                    var.terms[t].1.degree(x[v].clamp(var.range.0, var.range.1))
                })
                .fold(1.0, f64::min);
            for &(o, t) in &rule.then {
                let s = &mut scratch.strength[o][t];
                *s = s.max(w);
            }
        }
        for (o, var) in self.outputs.iter().enumerate() {
            let (lo, hi) = var.range;
            let (mut num, mut den) = (0.0, 0.0);
            for k in 0..RESOLUTION {
                let mu = self.tables[o]
                    .iter()
                    .zip(&scratch.strength[o])
                    .map(|(table, &w)| table[k].min(w))
                    .fold(0.0, f64::max);
                // Trapezoidal weights: the end points stand for half a cell each.
                let mu = if k == 0 || k == RESOLUTION - 1 {
                    0.5 * mu
                } else {
                    mu
                };
                num += mu * k as f64;
                den += mu;
            }
            out[o] = if den > 0.0 {
                lo + (hi - lo) * num / den / (RESOLUTION - 1) as f64
            } else {
                0.5 * (lo + hi)
            };
        }
    }
}

/// Parse `if <in> is <term> [and ...] then <out> is <term>[, ...]`.
fn parse_rule(text: &str, inputs: &[Variable], outputs: &[Variable]) -> Result<Rule, String> {
    let body = text
        .trim()
        .strip_prefix("if ")
        .ok_or("must start with 'if '")?;
    let (when, then) = body.split_once(" then ").ok_or("has no ' then '")?;
    let clause = |c: &str, vars: &[Variable], side: &str| -> Result<(usize, usize), String> {
        let (name, term) = c
            .trim()
            .split_once(" is ")
            .ok_or_else(|| format!("'{}' is not '<variable> is <term>'", c.trim()))?;
        let (name, term) = (name.trim(), term.trim());
        let v = vars
            .iter()
            .position(|v| v.name == name)
            .ok_or_else(|| format!("'{name}' is not an {side} variable"))?;
        let t = vars[v]
            .term(term)
            .ok_or_else(|| format!("'{term}' is not a set of '{name}'"))?;
        Ok((v, t))
    };
    let when = when
        .split(" and ")
        .map(|c| clause(c, inputs, "input"))
        .collect::<Result<Vec<_>, _>>()?;
    let then = then
        .split(',')
        .map(|c| clause(c, outputs, "output"))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Rule { when, then })
}

impl fmt::Display for Mamdani {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = |vars: &[Variable], (v, t): (usize, usize)| {
            format!("{} is {}", vars[v].name, vars[v].terms[t].0)
        };
        for (i, r) in self.rules.iter().enumerate() {
            let when: Vec<String> = r.when.iter().map(|&c| name(&self.inputs, c)).collect();
            let then: Vec<String> = r.then.iter().map(|&c| name(&self.outputs, c)).collect();
            writeln!(
                f,
                "{}) if {} then {}",
                i + 1,
                when.join(" and "),
                then.join(", ")
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tip() -> Mamdani {
        Mamdani::new(
            vec![Variable::new(
                "service",
                (0.0, 10.0),
                &[
                    ("poor", Set::left_shoulder(0.0, 5.0)),
                    ("good", Set::right_shoulder(5.0, 10.0)),
                ],
            )],
            vec![Variable::new(
                "tip",
                (0.0, 30.0),
                &[
                    (
                        "low",
                        Set::Triangle {
                            a: 0.0,
                            b: 0.0,
                            c: 10.0,
                        },
                    ),
                    (
                        "high",
                        Set::Triangle {
                            a: 20.0,
                            b: 30.0,
                            c: 30.0,
                        },
                    ),
                ],
            )],
            &[
                "if service is poor then tip is low",
                "if service is good then tip is high",
            ],
        )
        .unwrap()
    }

    fn run(m: &Mamdani, x: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; m.outputs().len()];
        m.infer(x, &mut m.scratch(), &mut out);
        out
    }

    #[test]
    fn memberships() {
        let t = Set::Triangle {
            a: 0.0,
            b: 1.0,
            c: 3.0,
        };
        assert_eq!(t.degree(-1.0), 0.0);
        assert_eq!(t.degree(0.5), 0.5);
        assert_eq!(t.degree(1.0), 1.0);
        assert_eq!(t.degree(2.0), 0.5);
        let s = Set::left_shoulder(2.0, 4.0);
        assert_eq!(s.degree(-1e9), 1.0);
        assert_eq!(s.degree(3.0), 0.5);
        assert_eq!(s.degree(4.0), 0.0);
        let s = Set::right_shoulder(2.0, 4.0);
        assert_eq!(s.degree(1e9), 1.0);
        assert_eq!(s.degree(3.0), 0.5);
    }

    #[test]
    fn one_rule_firing_gives_its_sets_centroid() {
        // Only "poor" fires, fully: the centroid of the triangle (0, 0, 10) is 10/3.
        let out = run(&tip(), &[0.0]);
        assert!((out[0] - 10.0 / 3.0).abs() < 0.05, "{out:?}");
        let out = run(&tip(), &[10.0]);
        assert!((out[0] - (30.0 - 10.0 / 3.0)).abs() < 0.05, "{out:?}");
    }

    #[test]
    fn symmetric_rules_balance_in_the_middle_and_output_is_monotone() {
        let out = run(&tip(), &[5.0]);
        assert!(
            (out[0] - 15.0).abs() < 1e-9,
            "nothing fires: mid-range, {out:?}"
        );
        let mut last = f64::NEG_INFINITY;
        for k in 0..=20 {
            let y = run(&tip(), &[k as f64 * 0.5])[0];
            assert!(y >= last - 1e-9, "{k}: {y} < {last}");
            last = y;
        }
        assert_eq!(run(&tip(), &[-50.0]), run(&tip(), &[0.0]), "clamped");
    }

    #[test]
    fn clipped_sets_by_hand() {
        // service = 4: poor 0.2; good 0. Aggregate: min(0.2, low). Its centroid, by
        // integrating the clipped triangle: the flat top on [0, 8] and the ramp on [8, 10].
        let out = run(&tip(), &[4.0])[0];
        let num = 0.2 * 8.0 * 4.0 + (0.2 * 2.0 / 2.0) * (8.0 + 2.0 / 3.0);
        let den = 0.2 * 8.0 + 0.2 * 2.0 / 2.0;
        assert!((out - num / den).abs() < 0.05, "{out} vs {}", num / den);
    }

    #[test]
    fn bad_systems_are_rejected_with_the_rule_and_reason() {
        let bad = |rule: &str| {
            Mamdani::new(tip().inputs().to_vec(), tip().outputs().to_vec(), &[rule])
                .unwrap_err()
                .to_string()
        };
        let e = bad("service is poor then tip is low");
        assert!(
            e.contains("rule 1") && e.contains("must start with 'if '"),
            "{e}"
        );
        let e = bad("if service is awful then tip is low");
        assert!(e.contains("'awful' is not a set of 'service'"), "{e}");
        let e = bad("if food is poor then tip is low");
        assert!(e.contains("'food' is not an input variable"), "{e}");
        let e = bad("if service is poor then service is poor");
        assert!(e.contains("'service' is not an output variable"), "{e}");
        let e = bad("if service is poor");
        assert!(e.contains("no ' then '"), "{e}");
        let e = Mamdani::new(vec![Variable::new("x", (1.0, 0.0), &[])], vec![], &[]).unwrap_err();
        assert_eq!(e, FuzzyError::Range("x".into()));
        let e = Mamdani::new(
            vec![Variable::new(
                "x",
                (0.0, 1.0),
                &[(
                    "a",
                    Set::Triangle {
                        a: 1.0,
                        b: 0.0,
                        c: 2.0,
                    },
                )],
            )],
            vec![],
            &[],
        )
        .unwrap_err();
        assert!(matches!(e, FuzzyError::Set { .. }), "{e}");
    }

    #[test]
    fn display_round_trips_the_rules() {
        let m = tip();
        let text = m.to_string();
        assert!(
            text.contains("1) if service is poor then tip is low"),
            "{text}"
        );
    }
}
