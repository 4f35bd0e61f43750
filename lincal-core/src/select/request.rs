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

/// The memory a plan may fill with its whitened Jacobian blocks: 80 % of the memory this
/// machine has available (Linux, `MemAvailable` of `/proc/meminfo`), else 8 GB. A plan's
/// peak is about its blocks, `(draws + 1)·Σ rows·params·8` bytes (a pool of 10⁶ planar
/// poses at 100 draws: 12.9 GB of blocks, 12.8 GB peak); past the memory there is, the
/// process would be killed with nothing said.
pub(super) fn design_budget() -> u64 {
    let available = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            text.lines()
                .find_map(|l| l.strip_prefix("MemAvailable:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
                .map(|kb| kb.saturating_mul(1024))
        });
    available.map_or(8_000_000_000, |b| b / 5 * 4)
}

/// Refuses a design of more than `budget` bytes of blocks: `rows` residual rows over the
/// pool, `params` estimated parameters (an upper bound on the free ones), `points`
/// parameter vectors (the draws and the nominals), before any block is built. `generated`
/// names `--pool` rather than `--candidates` as the pool's option.
pub(super) fn check_design_size(
    rows: usize,
    params: usize,
    points: usize,
    generated: bool,
    budget: u64,
) -> Result<()> {
    let bytes = (rows as u128) * (params as u128) * (points as u128) * 8;
    if bytes <= u128::from(budget) {
        return Ok(());
    }
    let gb = |b: f64| b / 1e9;
    Err(bad(
        if generated { "--pool" } else { "--candidates" },
        format!(
            "the plan would hold {:.1} GB of Jacobians ({rows} residual rows of the pool × \
             {params} parameters × {points} parameter draws, nominals included), more than \
             the {:.1} GB of memory it may take here: plan on a smaller pool, or with fewer \
             --draws",
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

/// Refuses a design too large for the memory here ([`check_design_size`], [`design_budget`]):
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
    let rows = match (pool, generated) {
        (Some(pool), _) => (0..pool.len())
            .map(|l| rows_of(pool.constraint.at(l)))
            .sum(),
        (None, Some(m)) => {
            let most = (0..model.constraint_count())
                .map(rows_of)
                .max()
                .unwrap_or(0);
            m.saturating_mul(most)
        }
        (None, None) => return Ok(()),
    };
    check_design_size(
        rows,
        model.param_count(),
        points,
        generated.is_some(),
        design_budget(),
    )
}
