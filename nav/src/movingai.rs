//! The MovingAI grid benchmark formats (Sturtevant, "Benchmarks for Grid-Based
//! Pathfinding", 2012): `.map` files and `.scen` problem lists.
//!
//! Terrain: `.`, `G` and `S` (swamp) are passable; `@`, `O` (out of bounds), `T` (trees)
//! and `W` are not. The benchmark rules let water be crossed only from water; no published
//! scenario of the octile set relies on it, so we treat it as impassable and say so.

use super::grid_search::{Cell, CostGrid};

/// Why a benchmark file was refused; the line is 1-based.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("line {line}: {reason}")]
pub struct FormatError {
    pub line: usize,
    pub reason: String,
}

fn err(line: usize, reason: impl Into<String>) -> FormatError {
    FormatError {
        line,
        reason: reason.into(),
    }
}

/// Parse a `.map` file.
pub fn parse_map(text: &str) -> Result<CostGrid, FormatError> {
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l.trim_end()));
    let mut header = |name: &str| -> Result<String, FormatError> {
        let (n, l) = lines
            .next()
            .ok_or_else(|| err(0, format!("missing '{name}' line")))?;
        let mut words = l.split_whitespace();
        if words.next() != Some(name) {
            return Err(err(n, format!("expected '{name}', found '{l}'")));
        }
        Ok(words.next().unwrap_or_default().to_owned())
    };
    let kind = header("type")?;
    if kind != "octile" {
        return Err(err(1, format!("map type '{kind}' is not octile")));
    }
    let number = |v: String, what: &str, line: usize| {
        v.parse::<usize>()
            .ok()
            .filter(|n| (1..=100_000).contains(n))
            .ok_or_else(|| err(line, format!("{what} '{v}' is not a size")))
    };
    let height = number(header("height")?, "height", 2)?;
    let width = number(header("width")?, "width", 3)?;
    header("map")?;
    let mut passable = Vec::with_capacity(width * height);
    let mut rows = 0;
    for (n, l) in lines {
        if l.is_empty() && rows == height {
            continue;
        }
        if rows == height {
            return Err(err(n, format!("more than the {height} rows announced")));
        }
        if l.len() != width {
            return Err(err(
                n,
                format!("{} cells, the map is {width} wide", l.len()),
            ));
        }
        for (c, ch) in l.chars().enumerate() {
            passable.push(match ch {
                '.' | 'G' | 'S' => true,
                '@' | 'O' | 'T' | 'W' => false,
                other => return Err(err(n, format!("unknown terrain '{other}' at column {c}"))),
            });
        }
        rows += 1;
    }
    if rows != height {
        return Err(err(4 + rows, format!("{rows} rows, {height} announced")));
    }
    Ok(CostGrid::from_passable(width, height, &passable).expect("sizes checked"))
}

/// One benchmark problem.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    pub start: Cell,
    pub goal: Cell,
    /// The optimal path length the benchmark gives.
    pub optimal: f64,
}

/// Parse a `.scen` file (version 1) for a map of `size` (width, height).
pub fn parse_scen(text: &str, size: (usize, usize)) -> Result<Vec<Problem>, FormatError> {
    let mut problems = Vec::new();
    for (i, l) in text.lines().enumerate() {
        let n = i + 1;
        if l.trim().is_empty() || (n == 1 && l.trim_start().starts_with("version")) {
            continue;
        }
        let f: Vec<&str> = l.split('\t').collect();
        if f.len() != 9 {
            return Err(err(
                n,
                format!("{} tab-separated fields, expected 9", f.len()),
            ));
        }
        let int = |k: usize, what: &str| {
            f[k].trim()
                .parse::<usize>()
                .map_err(|_| err(n, format!("{what} '{}' is not a whole number", f[k])))
        };
        let (w, h) = (int(2, "map width")?, int(3, "map height")?);
        if (w, h) != size {
            return Err(err(
                n,
                format!("for a {w} x {h} map, this map is {} x {}", size.0, size.1),
            ));
        }
        let start = (int(4, "start x")?, int(5, "start y")?);
        let goal = (int(6, "goal x")?, int(7, "goal y")?);
        for (what, (x, y)) in [("start", start), ("goal", goal)] {
            if x >= w || y >= h {
                return Err(err(n, format!("{what} ({x}, {y}) is off the map")));
            }
        }
        let optimal = f[8]
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| err(n, format!("optimal length '{}' is not a length", f[8])))?;
        problems.push(Problem {
            start,
            goal,
            optimal,
        });
    }
    Ok(problems)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAP: &str = "type octile\nheight 3\nwidth 4\nmap\n....\n.@@.\n....\n";

    #[test]
    fn a_map_and_its_scenarios_parse_and_solve_to_the_given_optimum() {
        let g = parse_map(MAP).unwrap();
        assert_eq!(g.size(), (4, 3));
        assert!(!g.passable((1, 1)) && g.passable((0, 1)));
        // Round the wall: no diagonal past its corners, so 5 straight moves.
        let scen = "version 1\n0\tm.map\t4\t3\t0\t1\t3\t1\t5\n";
        let p = parse_scen(scen, g.size()).unwrap();
        assert_eq!(p.len(), 1);
        let (len, _) = g.astar(p[0].start, p[0].goal).unwrap();
        assert!((len - p[0].optimal).abs() < 1e-6, "{len}");
    }

    #[test]
    fn bad_files_name_the_line_and_the_reason() {
        let e = parse_map(&MAP.replace(".@@.", ".@x.")).unwrap_err();
        assert_eq!(e.line, 6);
        assert!(e.reason.contains("unknown terrain 'x'"), "{e}");
        let e = parse_map(&MAP.replace("width 4", "width 5")).unwrap_err();
        assert!(e.reason.contains("the map is 5 wide"), "{e}");
        let e = parse_map(&MAP.replace("type octile", "type hex")).unwrap_err();
        assert_eq!(e.line, 1);
        let e = parse_scen("version 1\n0\tm.map\t4\t3\t0\t9\t3\t1\t4.8\n", (4, 3)).unwrap_err();
        assert!(e.line == 2 && e.reason.contains("off the map"), "{e}");
        let e = parse_scen("0\tm.map\t4\t3\t0\t1\t3\t1\n", (4, 3)).unwrap_err();
        assert!(e.reason.contains("8 tab-separated fields"), "{e}");
        let e = parse_scen("0\tm.map\t8\t3\t0\t1\t3\t1\t2\n", (4, 3)).unwrap_err();
        assert!(e.reason.contains("this map is 4 x 3"), "{e}");
    }
}
