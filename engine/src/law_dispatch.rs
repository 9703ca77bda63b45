//! The one place where the plan's contact laws and the core's switches become types: every
//! loop that is monomorphised over (normal law, tangential law) × flags is called through
//! [`with_laws!`](crate::with_laws) or [`with_flags!`](crate::with_flags). A new law is one
//! more arm here (and its `NormalLaw`/`TangentialLaw` impl), not a sixth ladder to keep in
//! step with five others.
//!
//! ```ignore
//! // run::<N, T, DASHPOT, ROT>(m, plan) with N, T the plan's laws:
//! with_laws!(plan, run[plan.dashpot, plan.rotation](m, plan))
//! // integrate_loop::<DAMP, LOCAL>(m) for two runtime switches:
//! with_flags!(integrate_loop[damp, local](m))
//! ```

/// Calls `f::<N, T, …flags>(args)` with `N`, `T` the plan's normal and tangential laws
/// (`plan.normal`, `plan.tangential`) and each runtime `bool` flag as a const generic.
#[macro_export]
macro_rules! with_laws {
    ($plan:expr, $f:ident[$($flag:expr),* $(,)?]($($arg:expr),* $(,)?)) => {{
        use $crate::model::{NormalKind, TangentialKind};
        use $crate::physics::contact_law::{Hertz, Linear, LinearShear, MindlinDampedShear, MindlinShear};
        match ($plan.normal, $plan.tangential) {
            (NormalKind::Linear, TangentialKind::Linear) => {
                $crate::with_flags!(@go $f [Linear, LinearShear,] [] [$($flag),*] ($($arg),*))
            }
            (NormalKind::Linear, TangentialKind::Mindlin) => {
                $crate::with_flags!(@go $f [Linear, MindlinShear,] [] [$($flag),*] ($($arg),*))
            }
            (NormalKind::Hertz, TangentialKind::Linear) => {
                $crate::with_flags!(@go $f [Hertz, LinearShear,] [] [$($flag),*] ($($arg),*))
            }
            (NormalKind::Hertz, TangentialKind::Mindlin) => {
                $crate::with_flags!(@go $f [Hertz, MindlinShear,] [] [$($flag),*] ($($arg),*))
            }
            (NormalKind::Linear, TangentialKind::MindlinDamped) => {
                $crate::with_flags!(@go $f [Linear, MindlinDampedShear,] [] [$($flag),*] ($($arg),*))
            }
            (NormalKind::Hertz, TangentialKind::MindlinDamped) => {
                $crate::with_flags!(@go $f [Hertz, MindlinDampedShear,] [] [$($flag),*] ($($arg),*))
            }
        }
    }};
}

/// Calls `f::<…flags>(args)` with each runtime `bool` flag as a const generic (2^flags
/// monomorphised calls, one branch each).
#[macro_export]
macro_rules! with_flags {
    (@go $f:ident [$($ty:ty,)*] [$($c:tt)*] [] ($($arg:expr),*)) => {
        $f::<$($ty,)* $($c)*>($($arg),*)
    };
    (@go $f:ident [$($ty:ty,)*] [$($c:tt)*] [$flag:expr $(, $rest:expr)*] ($($arg:expr),*)) => {
        if $flag {
            $crate::with_flags!(@go $f [$($ty,)*] [$($c)* true,] [$($rest),*] ($($arg),*))
        } else {
            $crate::with_flags!(@go $f [$($ty,)*] [$($c)* false,] [$($rest),*] ($($arg),*))
        }
    };
    ($f:ident[$($flag:expr),+ $(,)?]($($arg:expr),* $(,)?)) => {
        $crate::with_flags!(@go $f [] [] [$($flag),+] ($($arg),*))
    };
}
