//! What a plan may be asked for: the bounds of a request (`--pool`, `--draws`) and its count
//! against the pool, checked before (and right after) the pool is built, so that a request
//! that cannot be met, or would run for hours, is refused by name.

use crate::error::{Error, Location, Result};
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
