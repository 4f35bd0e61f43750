use lincal_derive::CalibModel;

#[derive(CalibModel)]
#[calib(spec = "specs/no_such_robot.yaml")]
struct Robot;

fn main() {}
