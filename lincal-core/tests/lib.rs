//! Integration tests of lincal-core: one test binary (link time on 2 cores).
mod architecture;
mod numeric;
