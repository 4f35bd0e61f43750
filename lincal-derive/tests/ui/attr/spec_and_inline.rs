use lincal_derive::CalibModel;

#[derive(CalibModel)]
#[calib(spec = "specs/robot.yaml", dim = 2)]
struct Robot;

fn main() {}
