//! What a plan may be asked for: the bounds of a request (`--pool`, `--draws`), its count
//! against the pool and its design's size against the memory there is, checked before (and
//! right after) the pool is built, so that a request that cannot be met, would run for hours
//! or would be killed for its memory is refused by name.

use crate::data::Poses;
use crate::error::{Error, Location, Result};
use crate::model::CalibModel;
use crate::simulate::Noise;

/// Most poses of a generated pool (`--pool`): a candidates file of the largest size read
/// holds about as many rows of a 7-joint arm, and the pool's memory and time grow with it.
pub const MAX_POOL: usize = 1_000_000;

/// Most parameter draws (`--draws`): the criterion's cost grows linearly with them, and a
/// few already keep special nominals from blinding it.
pub const MAX_DRAWS: usize = 100;

/// Refuses a generated pool (`generated` poses) of 0 or above [`MAX_POOL`] and `draws` above
/// [`MAX_DRAWS`] before any work (an unbounded request would run for hours or exhaust
/// memory). [`crate::select::plan::plan`] checks them; a front end may check first, before
/// it reads the spec.
///
/// # Errors
/// An input error naming `--pool` or `--draws`.
pub fn check_sizes(generated: Option<usize>, draws: usize) -> Result<()> {
    if let Some(m) = generated {
        if m == 0 || m > MAX_POOL {
            return Err(bad(
                "--pool",
                format!("a pool of {m} poses: give 1 to {MAX_POOL}"),
            ));
        }
    }
    if draws > MAX_DRAWS {
        return Err(bad(
            "--draws",
            format!("{draws} draws: give 0 to {MAX_DRAWS}"),
        ));
    }
    Ok(())
}

/// The smallest noise level a plan takes (metres or radians; 0 stays "the default"): each
/// pose's residual is divided by its level, and far below any real sensor that scaling
/// overflows the information matrix (`1e-160` does) where the design itself does not change.
pub const MIN_NOISE: f64 = 1e-12;

/// Refuses a noise level above 0 and below [`MIN_NOISE`], naming its option.
///
/// # Errors
/// An input error naming the option (`--noise-track`, …).
pub fn check_noise_floor(noise: Noise) -> Result<()> {
    for (option, level) in noise.levels() {
        if level > 0.0 && level < MIN_NOISE {
            return Err(bad(
                option,
                format!("{level:e} is below {MIN_NOISE:e}: give a real sensor's level, or 0"),
            ));
        }
    }
    Ok(())
}

/// The bytes a plan's design takes at its peak, about: each of the `points` parameter
/// vectors (the draws and the nominals) holds its whitened block of `rows × params`, one more
/// is being built (the unwhitened Jacobians, a column more), and the selection's records add
/// about `most_rows` columns (the rank-`m` updates, `m` a pose's rows). Measured: a pool of
/// 10⁶ planar poses (2 rows, 8 parameters) at 100 draws peaked at 12.8 GB, estimated 18 GB.
pub(super) fn design_bytes(rows: usize, params: usize, points: usize, most_rows: usize) -> u128 {
    [
        rows as u128,
        params as u128 + 1 + most_rows as u128,
        points as u128 + 1,
        8,
    ]
    .into_iter()
    .fold(1, u128::saturating_mul)
}

/// Refuses a design of more than `budget` bytes ([`design_bytes`]): `rows` residual rows over
/// the pool (each pose at most `most_rows`), `params` estimated parameters (an upper bound on
/// the free ones), `points` parameter vectors (the draws and the nominals), before any block
/// is built. `generated` names `--pool` rather than `--candidates` as the pool's option.
pub(super) fn check_design_size(
    rows: usize,
    most_rows: usize,
    params: usize,
    points: usize,
    generated: bool,
    budget: u64,
) -> Result<()> {
    let bytes = design_bytes(rows, params, points, most_rows);
    if bytes <= u128::from(budget) {
        return Ok(());
    }
    let gb = |b: f64| b / 1e9;
    Err(bad(
        if generated { "--pool" } else { "--candidates" },
        format!(
            "the plan would take about {:.1} GB for its Jacobians ({rows} residual rows of the \
             pool × {params} parameters × {points} parameter draws, nominals included), more \
             than the {:.1} GB of memory it may take here: plan on a smaller pool, or with \
             fewer --draws",
            gb(bytes as f64),
            gb(budget as f64)
        ),
    ))
}

/// Refuses `count` poses from a pool of `pool_len` on the constraint (`dropped` candidates
/// were off it): none at all, or more than the pool holds.
pub(super) fn check_count(count: usize, pool_len: usize, dropped: usize) -> Result<()> {
    if pool_len == 0 && dropped > 0 {
        return Err(bad(
            "--candidates",
            format!(
                "no candidate lies on the nominal constraint ({dropped} dropped as off it by \
                 more than --max-off): check the spec's nominal constraint values, or raise \
                 --max-off"
            ),
        ));
    }
    if pool_len == 0 {
        return Err(bad(
            "--candidates",
            format!(
                "the candidates hold no poses (a header and no rows?): give at least {count} \
                 candidate rows, or let --pool generate them"
            ),
        ));
    }
    if count == 0 || count > pool_len {
        return Err(bad(
            "-n",
            format!(
                "{count} poses asked from a pool of {pool_len} on the constraint{}: ask for 1 \
                 to {pool_len}",
                if dropped == 0 {
                    String::new()
                } else {
                    format!(" ({dropped} candidates dropped as off it)")
                },
            ),
        ));
    }
    Ok(())
}

/// The most work a plan may take: candidates × poses asked × parameters² × parameter points
/// (the draws and the nominals). Measured on this project's 2-core machine: 1.2·10¹¹ (10⁵
/// candidates, 200 poses, 38 parameters) plans in 4 s, 2.2·10¹¹ in under a minute, while
/// 7·10¹¹ took 138 s and 4.5·10¹² 154 s; beyond the bound a plan is refused before any work,
/// naming the options that shrink it.
pub const MAX_PLAN_WORK: f64 = 3e11;

/// Refuses a plan whose work ([`MAX_PLAN_WORK`]) is beyond the bound: `candidates` in the
/// pool (`generated`: by `--pool`), `count` poses asked, `params` parameters, `points`
/// parameter points.
pub(super) fn check_work(
    candidates: usize,
    count: usize,
    params: usize,
    points: usize,
    generated: bool,
) -> Result<()> {
    let work = candidates as f64 * count as f64 * (params as f64).powi(2) * points as f64;
    if work <= MAX_PLAN_WORK {
        return Ok(());
    }
    Err(bad(
        if generated { "--pool" } else { "--candidates" },
        format!(
            "the plan would take about {work:.1e} operations ({candidates} candidates × \
             {count} poses × {params}² parameters × {points} parameter points, the draws and \
             the nominals), beyond the {MAX_PLAN_WORK:.0e} planned in about a minute: plan \
             from a smaller pool, ask for fewer poses (-n), or take fewer --draws"
        ),
    ))
}

/// An input error naming `field`.
pub(super) fn bad(field: &str, msg: String) -> Error {
    Error::input(
        Location {
            field: Some(field.to_string()),
            ..Location::default()
        },
        msg,
    )
}

/// Refuses a design too large for the memory here ([`check_design_size`], [`crate::memory::budget`]):
/// before the pool is built, a
/// generated one of `generated` poses at the most rows a pose can have; once built (`pool`),
/// the pool's own rows.
pub(super) fn design_fits(
    model: &dyn CalibModel,
    points: usize,
    generated: Option<usize>,
    pool: Option<&Poses>,
) -> Result<()> {
    let rows_of = |j: usize| model.constraint_kind(j).residual_count(model.dim());
    let most = (0..model.constraint_count())
        .map(rows_of)
        .max()
        .unwrap_or(0);
    let rows = match (pool, generated) {
        (Some(pool), _) => (0..pool.len())
            .map(|l| rows_of(pool.constraint.at(l)))
            .sum(),
        (None, Some(m)) => m.saturating_mul(most),
        (None, None) => return Ok(()),
    };
    check_design_size(
        rows,
        most,
        model.param_count(),
        points,
        generated.is_some(),
        crate::memory::budget(),
    )
}

/// The plan's memory and work within bounds ([`design_fits`], [`check_work`]): before the
/// pool is built for a generated one of `generated` poses, and once built (`pool`).
pub(super) fn affordable(
    model: &dyn CalibModel,
    points: usize,
    generated: Option<usize>,
    pool: Option<&Poses>,
    count: usize,
) -> Result<()> {
    design_fits(model, points, generated, pool)?;
    let np = model.param_count();
    match (pool, generated) {
        (Some(pool), _) => check_work(pool.len(), count, np, points, generated.is_some()),
        (None, Some(m)) => check_work(m, count, np, points, true),
        (None, None) => Ok(()),
    }
}

/// Every constraint of the list whose own values are free parameters has a candidate (or a
/// pose given): no choice of poses sees a socket that no pose stands in (exit 2, naming the
/// constraints and their values).
pub(super) fn check_every_constraint(
    model: &dyn CalibModel,
    pool: &Poses,
    given: Option<&Poses>,
) -> Result<()> {
    let mut seen = vec![false; model.constraint_count()];
    for c in pool
        .constraint
        .iter()
        .chain(given.iter().flat_map(|g| g.constraint.iter()))
    {
        if let Some(s) = seen.get_mut(c) {
            *s = true;
        }
    }
    let blind: Vec<String> = (0..model.constraint_count())
        .filter(|&j| !seen[j])
        .filter_map(|j| {
            let values: Vec<&str> = (0..model.constraint_kind(j).value_count(model.dim()))
                .filter_map(|v| model.constraint_value_param(j, v))
                .filter(|&p| !model.param_held(p))
                .map(|p| model.param_name(p))
                .collect();
            (!values.is_empty()).then(|| format!("{j} ({})", values.join(", ")))
        })
        .collect();
    if blind.is_empty() {
        return Ok(());
    }
    Err(Error::input(
        Location {
            field: Some("constraint".to_string()),
            ..Location::default()
        },
        format!(
            "the candidates have no pose on constraint(s) {}, whose values no choice of poses \
             can then see: give candidates on every constraint of the list (a `constraint` \
             column), or make those values known",
            blind.join("; ")
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The estimate counts every draw's block, one more being built and the records; a
    /// design over the budget is refused naming the pool's option and the remedy, one within
    /// it passes; sizes whose products overflow `usize` do not wrap.
    #[test]
    fn a_design_over_the_budget_is_refused_by_name() {
        assert_eq!(design_bytes(10, 4, 2, 1), 10 * 6 * 3 * 8);
        let budget = u64::try_from(design_bytes(1000, 8, 4, 2)).expect("small");
        assert!(check_design_size(1000, 2, 8, 4, true, budget).is_ok());
        let err = check_design_size(1001, 2, 8, 4, true, budget)
            .expect_err("over the budget")
            .to_string();
        assert!(
            err.contains("--pool") && err.contains("fewer --draws"),
            "{err}"
        );
        let err = check_design_size(usize::MAX, 6, usize::MAX / 2, 101, false, u64::MAX)
            .expect_err("far over")
            .to_string();
        assert!(err.contains("--candidates"), "{err}");
        assert!(crate::memory::budget() > 0);
    }
}
