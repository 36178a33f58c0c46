//! `cubetrace bench`: the harness end to end on one small scene (`bench_harness`) and the glossy
//! ladder of `bench --glossy` (`bench_glossy`). The cost model's reports are in
//! `tests/model.rs`.

mod common;

#[path = "bench/bench_glossy.rs"]
mod bench_glossy;
#[path = "bench/bench_harness.rs"]
mod bench_harness;
