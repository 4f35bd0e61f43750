use lincal_derive::CalibModel;

#[derive(CalibModel)]
#[calib(
    dim = 3,
    joint(revolute, a = a1 + 0.1, alpha = pi*pi, home = th1),
    joint(revolute, a = 0.3, alpha = a2, limits = [1, -1]),
    params(a1 = 0.4, th1 = 0, a2 = 0.1, b1 = -1.8, b2 = 0.5, b3 = 1),
    constraint(plane(b = [b1, b2, b3])),
)]
struct Robot;

fn main() {}
