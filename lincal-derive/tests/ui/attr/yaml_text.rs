use lincal_derive::CalibModel;

#[derive(CalibModel)]
#[calib(yaml = "
name: robot
dim: 4
joints:
  - {type: revolute, a: a1, home: th1}
params:
  a1: {nominal: 0.4}
  th1: {nominal: 0}
constraint: measured
")]
struct Robot;

fn main() {}
