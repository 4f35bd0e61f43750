use lincal_derive::CalibModel;

#[derive(CalibModel)]
#[calib(spec = "tests/ui/file/bad_yaml.yaml")]
struct Robot;

fn main() {}
