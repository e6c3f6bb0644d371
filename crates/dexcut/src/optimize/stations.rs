//! The free stations the rounds plan on, and their path while they are let
//! go.

use crate::error::{fail, Result};
use nc::Motion;
use schedule::{FeedPolicy, Machine, Stations};

use crate::motion::STATION_DS_MM;
use crate::setup::Setup;

/// The free stations of the rounds ([`free_stations_of`]), or, while the
/// written program is verified, the path they are made from alone, or not
/// even that: their arrays (a million-block program's 3 M stations: 143 MB)
/// are let go from the re-feed on and made again when a next round plans,
/// and a G-code program's path is handed to the re-feed and read again from
/// its text where it is needed (126 MB).
pub enum FreeStations {
    /// The stations, their caps as made.
    Made(Box<Stations>),
    /// Their path, the stations let go.
    Released(nc::Path),
    /// Neither: the path was handed over ([`FreeStations::give`]); it is the
    /// program's text read again ([`Setup::program_path_again`]).
    Given,
}

impl FreeStations {
    /// The program's path, taken out (read again where it was given),
    /// `self` left [`FreeStations::Given`].
    pub fn give(&mut self, setup: &Setup) -> Result<nc::Path> {
        match std::mem::replace(self, FreeStations::Given) {
            FreeStations::Made(stations) => Ok(stations.into_path()),
            FreeStations::Released(path) => Ok(path),
            FreeStations::Given => setup.program_path_again(),
        }
    }

    /// `f` of the program's path the stations are made from (read again
    /// where it was given, and then held).
    pub fn with_path<T>(&mut self, setup: &Setup, f: impl FnOnce(&nc::Path) -> T) -> Result<T> {
        if let FreeStations::Made(stations) = self {
            return Ok(f(stations.path()));
        }
        let path = self.give(setup)?;
        let out = f(&path);
        *self = FreeStations::Released(path);
        Ok(out)
    }

    /// The stations, made again from the path by `machine` (as
    /// [`free_stations_of`] made them) where they were let go.
    pub fn stations(&mut self, machine: &Machine, setup: &Setup) -> Result<&mut Stations> {
        if !matches!(self, FreeStations::Made(_)) {
            let stations = free_stations_of(self.give(setup)?, machine).map_err(|failed| {
                let (e, path) = *failed;
                *self = FreeStations::Released(path);
                e
            })?;
            *self = FreeStations::Made(Box::new(stations));
        }
        match self {
            FreeStations::Made(stations) => Ok(&mut **stations),
            FreeStations::Released(_) | FreeStations::Given => unreachable!("made above"),
        }
    }

    /// Lets the stations' arrays go, keeping their path.
    pub fn release(&mut self) {
        *self = match std::mem::replace(self, FreeStations::Given) {
            FreeStations::Made(stations) => FreeStations::Released(stations.into_path()),
            other => other,
        };
    }

    /// The path, given back (read again where it was given).
    pub fn into_path(mut self, setup: &Setup) -> Result<nc::Path> {
        self.give(setup)
    }
}

/// Stations for re-timing with every feed block free up to feed_max.
pub fn free_stations(path: &nc::Path, machine: &Machine) -> Result<Stations> {
    has_feed_moves(path)?;
    Ok(Stations::new(
        path,
        machine,
        STATION_DS_MM,
        FeedPolicy::MachineMax,
    )?)
}

/// [`free_stations`] on a path handed to the stations rather than copied
/// (a million-block path is about 120 MB; [`Stations::into_path`] gives it
/// back); on an error the path comes back with it (boxed: the pair is large).
pub fn free_stations_of(
    path: nc::Path,
    machine: &Machine,
) -> std::result::Result<Stations, Box<(crate::error::Error, nc::Path)>> {
    if let Err(e) = has_feed_moves(&path) {
        return Err(Box::new((e, path)));
    }
    Stations::from_path(path, machine, STATION_DS_MM, FeedPolicy::MachineMax)
        .map_err(|(e, path)| Box::new((e.into(), path)))
}

fn has_feed_moves(path: &nc::Path) -> Result<()> {
    if path
        .segments
        .iter()
        .all(|s| !matches!(s.motion, Motion::Feed { .. }))
    {
        fail!(run, "the program has no feed moves to optimise");
    }
    Ok(())
}
