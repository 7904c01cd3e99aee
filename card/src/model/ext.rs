//! Variable families a command language defines beyond the model's own I/P/Q/M variables
//! (thread-local variables, named data-structure elements, typed pointer variables): the
//! language installs an [`ExtVars`] in the model ([`super::CardModel::set_ext`]), the program
//! engine and the interpreter reach them as `VarKind::Ext(family)`. Dialect-neutral: the model
//! only carries the extension and the context of the evaluating thread ([`ExtAt`]).

use std::any::Any;

use super::CardModel;

/// The program thread an expression is evaluated for (its locals are its own).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Thread {
    /// A coordinate system's motion program (1-based C.S.).
    Cs(u16),
    /// An interpreted PLC (0-31).
    Plc(u8),
    /// A host connection's command thread.
    Host(u64),
    /// The kinematic subroutines of a coordinate system (1-based C.S.).
    Kin(u16),
    /// Commands issued by programs (`CMD"…"`), and everything else.
    #[default]
    Internal,
}

/// Where an extension variable is read or written from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExtAt {
    /// The evaluating thread.
    pub thread: Thread,
    /// Its addressed coordinate system (1-based).
    pub coord: u16,
    /// Its addressed motor (1-based).
    pub motor: u16,
    /// Local-variable stack slot of the running subroutine's `L0` (0: the top program).
    pub base: u32,
    /// The running program's stack offset: its `R0` is slot `base + offset`, the `L0` of a
    /// subroutine it calls (Power `open prog n,{offset}`, default [`DEFAULT_STACK_OFFSET`]).
    pub offset: u32,
}

/// The stack offset of a program that declares none (seed 000 L39880-39890).
pub(crate) const DEFAULT_STACK_OFFSET: u32 = 256;

impl Default for ExtAt {
    fn default() -> Self {
        ExtAt {
            thread: Thread::default(),
            coord: 0,
            motor: 0,
            base: 0,
            offset: DEFAULT_STACK_OFFSET,
        }
    }
}

impl ExtAt {
    /// A coordinate system's program whose `L0` is stack slot `base`, with stack offset
    /// `offset`.
    pub fn cs(cs: u16, base: u32, offset: u32) -> Self {
        ExtAt {
            thread: Thread::Cs(cs),
            coord: cs,
            motor: 1,
            base,
            offset,
        }
    }
}

/// The code a stack offset belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StackOf {
    /// Motion program or subprogram buffer `n` (model numbering).
    Prog(u16),
    /// PLC program `n`.
    Plc(u8),
}

/// Why an extension variable could not be read or written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExtError {
    /// No such variable (family or index).
    NoSuch,
    /// It cannot be written (a status element).
    ReadOnly,
    /// The value is out of the variable's range.
    Range,
}

/// A kinematic routine a language provides (see `ExtVars::kinematics`): its compiled code
/// (the engine's form, which the engine downcasts) and the variable families of motor
/// positions (KinPosMotor) and axis positions (KinPosAxis).
#[derive(Debug, Clone)]
pub struct KinRoutine {
    /// The compiled statements (`program::compile::Compiled`).
    pub code: std::sync::Arc<dyn Any + Send + Sync>,
    /// The variable family of motor positions.
    pub motor_family: u16,
    /// The variable family of axis positions.
    pub axis_family: u16,
}

/// A command language's own variable families.
pub trait ExtVars: std::fmt::Debug + Send {
    /// Value of `family` number `index`, as seen from `at`.
    fn read(
        &mut self,
        card: &mut CardModel,
        at: &ExtAt,
        family: u16,
        index: u32,
    ) -> Result<f64, ExtError>;
    /// Store `v` into `family` number `index`, as seen from `at`.
    fn write(
        &mut self,
        card: &mut CardModel,
        at: &ExtAt,
        family: u16,
        index: u32,
        v: f64,
    ) -> Result<(), ExtError>;
    /// The forward (`inverse` false) or inverse kinematic routine of C.S. `cs` (1-based),
    /// if the language has one.
    fn kinematics(&self, cs: u16, inverse: bool) -> Option<KinRoutine> {
        let _ = (cs, inverse);
        None
    }
    /// The stack offset the language gave `code` ([`DEFAULT_STACK_OFFSET`] unless it says).
    fn stack_offset(&self, code: StackOf) -> u32 {
        let _ = code;
        DEFAULT_STACK_OFFSET
    }
    /// The language's save hooks, if it adds a part to the saved image.
    fn image_hooks(&self) -> Option<super::ImageHooks> {
        None
    }
    /// The extension as `Any` (its language reaches its own state).
    fn as_any_mut(&mut self) -> &mut dyn Any;
    /// The extension as `Any`.
    fn as_any(&self) -> &dyn Any;
}

impl CardModel {
    /// Install the language's extension.
    pub fn set_ext(&mut self, ext: Box<dyn ExtVars>) {
        self.ext = Some(ext);
    }

    /// The installed extension, if it is a `T`.
    pub fn ext<T: 'static>(&self) -> Option<&T> {
        self.ext.as_ref()?.as_any().downcast_ref::<T>()
    }

    /// The installed extension, if it is a `T`.
    pub fn ext_mut<T: 'static>(&mut self) -> Option<&mut T> {
        self.ext.as_mut()?.as_any_mut().downcast_mut::<T>()
    }

    /// Take the extension out (to use it together with the model); put it back with
    /// [`CardModel::set_ext`].
    pub fn take_ext(&mut self) -> Option<Box<dyn ExtVars>> {
        self.ext.take()
    }

    /// The language's kinematic routine of C.S. `cs` (see `ExtVars::kinematics`).
    pub fn ext_kinematics(&self, cs: u16, inverse: bool) -> Option<KinRoutine> {
        self.ext.as_ref()?.kinematics(cs, inverse)
    }

    /// The stack offset of `code` (see `ExtVars::stack_offset`).
    pub fn stack_offset(&self, code: StackOf) -> u32 {
        self.ext
            .as_ref()
            .map_or(DEFAULT_STACK_OFFSET, |e| e.stack_offset(code))
    }

    /// Read `family` number `index` for `at`.
    pub fn ext_read(&mut self, at: &ExtAt, family: u16, index: u32) -> Result<f64, ExtError> {
        let Some(mut e) = self.ext.take() else {
            return Err(ExtError::NoSuch);
        };
        let r = e.read(self, at, family, index);
        if self.ext.is_none() {
            self.ext = Some(e);
        }
        r
    }

    /// Write `family` number `index` for `at`.
    pub fn ext_write(
        &mut self,
        at: &ExtAt,
        family: u16,
        index: u32,
        v: f64,
    ) -> Result<(), ExtError> {
        let Some(mut e) = self.ext.take() else {
            return Err(ExtError::NoSuch);
        };
        let r = e.write(self, at, family, index, v);
        if self.ext.is_none() {
            self.ext = Some(e);
        }
        r
    }
}
