use super::Fluid;
use crate::error::{SphError, SphResult};

/// A generational handle naming one fluid of a [`FluidSet`]: a removed fluid's handle never
/// names another fluid later inserted in its place.
///
/// # Examples
/// ```
/// use rapier_sph::{Fluid, FluidParamsBuilder, FluidSet};
/// let mut fluids = FluidSet::new();
/// let water = fluids.insert(Fluid::new(FluidParamsBuilder::water(0.05))?);
/// assert_eq!(fluids[water].params().rest_density, 1000.0);
/// fluids.remove(water)?;
/// let oil = fluids.insert(Fluid::new(FluidParamsBuilder::water(0.05).rest_density(900.0))?);
/// assert!(fluids.get(water).is_none()); // the old handle is stale, not the oil
/// assert!(fluids.get(oil).is_some());
/// # Ok::<(), rapier_sph::SphError>(())
/// ```
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct FluidHandle {
    index: u32,
    generation: u32,
}

#[derive(Clone, Debug)]
enum Entry {
    Occupied { generation: u32, fluid: Box<Fluid> },
    Vacant { generation: u32 },
}

/// All the fluids of a scene, each with its own parameters.
///
/// Each fluid interacts with the rapier colliders; fluids of one set interact with each other
/// when their [`crate::FluidParams::fluid_groups`] say so (default: they do not; see
/// [`crate::fluid::interaction`]).
///
/// # Examples
/// ```
/// use rapier_sph::{Fluid, FluidParamsBuilder, FluidSet, SphError};
/// let mut fluids = FluidSet::new();
/// let water = fluids.insert(Fluid::new(FluidParamsBuilder::water(0.05))?);
/// let oil = fluids.insert(Fluid::new(FluidParamsBuilder::water(0.05).rest_density(900.0))?);
/// assert_eq!(fluids.len(), 2);
/// assert_eq!(fluids[oil].params().rest_density, 900.0);
/// fluids.remove(water)?;
/// assert!(fluids.get(water).is_none()); // a stale handle names nothing
/// assert_eq!(fluids.remove(water).unwrap_err(), SphError::UnknownFluid);
/// # Ok::<(), SphError>(())
/// ```
#[derive(Clone, Debug, Default)]
pub struct FluidSet {
    entries: Vec<Entry>,
    free: Vec<u32>,
    len: usize,
}

impl FluidSet {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a fluid and returns its handle.
    pub fn insert(&mut self, fluid: Fluid) -> FluidHandle {
        self.len += 1;
        if let Some(index) = self.free.pop() {
            let generation = match self.entries[index as usize] {
                Entry::Vacant { generation } => generation + 1,
                Entry::Occupied { .. } => unreachable!("free list holds vacant slots only"),
            };
            self.entries[index as usize] = Entry::Occupied {
                generation,
                fluid: Box::new(fluid),
            };
            FluidHandle { index, generation }
        } else {
            self.entries.push(Entry::Occupied {
                generation: 0,
                fluid: Box::new(fluid),
            });
            FluidHandle {
                index: self.entries.len() as u32 - 1,
                generation: 0,
            }
        }
    }

    /// Removes a fluid, returning it.
    ///
    /// # Errors
    /// [`SphError::InvalidParameter`] when the handle names no fluid of the set (removed
    /// already, or from another set).
    pub fn remove(&mut self, handle: FluidHandle) -> SphResult<Fluid> {
        match self.entries.get(handle.index as usize) {
            Some(Entry::Occupied { generation, .. }) if *generation == handle.generation => {
                let old = std::mem::replace(
                    &mut self.entries[handle.index as usize],
                    Entry::Vacant {
                        generation: handle.generation,
                    },
                );
                self.free.push(handle.index);
                self.len -= 1;
                match old {
                    Entry::Occupied { fluid, .. } => Ok(*fluid),
                    Entry::Vacant { .. } => unreachable!(),
                }
            }
            _ => Err(SphError::UnknownFluid),
        }
    }

    /// The fluid named by `handle`.
    pub fn get(&self, handle: FluidHandle) -> Option<&Fluid> {
        match self.entries.get(handle.index as usize) {
            Some(Entry::Occupied { generation, fluid }) if *generation == handle.generation => {
                Some(fluid)
            }
            _ => None,
        }
    }

    /// The fluid named by `handle`, mutably.
    pub fn get_mut(&mut self, handle: FluidHandle) -> Option<&mut Fluid> {
        match self.entries.get_mut(handle.index as usize) {
            Some(Entry::Occupied { generation, fluid }) if *generation == handle.generation => {
                Some(fluid)
            }
            _ => None,
        }
    }

    /// Iterates over `(handle, fluid)`.
    pub fn iter(&self) -> impl Iterator<Item = (FluidHandle, &Fluid)> {
        self.entries
            .iter()
            .enumerate()
            .filter_map(|(i, e)| match e {
                Entry::Occupied { generation, fluid } => Some((
                    FluidHandle {
                        index: i as u32,
                        generation: *generation,
                    },
                    &**fluid,
                )),
                Entry::Vacant { .. } => None,
            })
    }

    /// Iterates mutably over `(handle, fluid)`.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = (FluidHandle, &mut Fluid)> {
        self.entries
            .iter_mut()
            .enumerate()
            .filter_map(|(i, e)| match e {
                Entry::Occupied { generation, fluid } => Some((
                    FluidHandle {
                        index: i as u32,
                        generation: *generation,
                    },
                    &mut **fluid,
                )),
                Entry::Vacant { .. } => None,
            })
    }

    /// Number of fluids.
    pub fn len(&self) -> usize {
        self.len
    }

    /// `true` when the set holds no fluid.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Total number of particles over all fluids.
    pub fn num_particles(&self) -> usize {
        self.iter().map(|(_, f)| f.len()).sum()
    }
}

impl std::ops::Index<FluidHandle> for FluidSet {
    type Output = Fluid;
    fn index(&self, handle: FluidHandle) -> &Fluid {
        self.get(handle)
            .expect("no fluid with this handle (use `get` to handle that case)")
    }
}

impl std::ops::IndexMut<FluidHandle> for FluidSet {
    fn index_mut(&mut self, handle: FluidHandle) -> &mut Fluid {
        self.get_mut(handle)
            .expect("no fluid with this handle (use `get_mut` to handle that case)")
    }
}
