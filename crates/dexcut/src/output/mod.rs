//! What the commands write into a results folder: the staged folder itself
//! ([`outdir`]), the steps ([`steps`]) and servo.csv ([`servo_csv`]).

pub mod outdir;
pub mod servo_csv;
pub mod steps;
