use lincal_derive::CalibModel;

#[derive(CalibModel)]
#[calib(dim = , joint(revolute))]
struct Robot;

fn main() {}
