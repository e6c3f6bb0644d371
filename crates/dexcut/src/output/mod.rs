//! What the commands write into a results folder: the staged folder itself
//! ([`outdir`]), the steps ([`steps`]), a run's steps and columns together
//! ([`run_files`]) and servo.csv ([`servo_csv`]).

pub mod outdir;
pub mod run_files;
pub mod servo_csv;
pub mod steps;
