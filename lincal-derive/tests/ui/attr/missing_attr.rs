use lincal_derive::CalibModel;

#[derive(CalibModel)]
struct Robot;

fn main() {}
