// ost_activation.h: actuator activation dynamics taken implicitly with the step (core/README.md
// section 1, eq. 8b). Mirrors the act_dot part of engine_forward.c's mj_fwdActuation and the
// activation update of mj_advance (MuJoCo 2.2.2), with backward Euler in place of MuJoCo's
// explicit Euler:
//   integrator  act_dot = ctrl                act+ = act- + h ctrl
//   filter      act_dot = (ctrl - act) / tau  act+ = (tau act- + h ctrl) / (tau + h)
//   muscle      mju_muscleDynamics             act+ solved exactly (ost_muscle.h, eq. 8c)
// then clamped to actrange when actlimited (mj_advance clamps after its update). ctrl is the
// control clamped to ctrlrange (mj_fwdActuation's local copy); tau = max(1e-15, dynprm[0]) as
// MuJoCo (mjMINVAL). An actuator with activation dynamics applies gain act+ + bias: its force
// is that of the end of the step, like every implicit quantity of the step.
// Activation i - (nu - na) belongs to actuator i (MuJoCo 2.2.2: stateful actuators come last).
// Invariant: pure functions of their arguments; written once for any scalar type (ostNum may
// be a dual number, so that the adjoint differentiates act+ exactly).
#ifndef OSTRICH_CORE_OST_ACTIVATION_H_
#define OSTRICH_CORE_OST_ACTIVATION_H_

#include "ost_hd.h"
#include "ost_model.h"
#include "ost_muscle.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum osttDyn_ {           // activation dynamics, numbered as mjtDyn
  OST_DYN_NONE = 0,               // no activation: the actuator applies ctrl
  OST_DYN_INTEGRATOR,             // act_dot = ctrl
  OST_DYN_FILTER,                 // act_dot = (ctrl - act) / tau
  OST_DYN_MUSCLE,                 // MuJoCo's muscle activation (ost_muscle.h)
  OST_DYN_USER                    // mjcb_act_dyn (refused)
} osttDyn;

// MuJoCo's mjMINVAL: the smallest filter time constant (mj_fwdActuation)
#define OST_ACT_MINTAU 1e-15


// c clamped to range[0], range[1] when limited
OST_HD ostNum osti_actClamp(ostNum c, int limited, const ostNum range[2]) {
  if (limited) {
    c = c < range[0] ? range[0] : (c > range[1] ? range[1] : c);
  }
  return c;
}


// act+ of one activation after a backward-Euler step of size h (eq. 8b): act- the activation
// at the start, ctrl the clamped control, dynprm the actuator's first two dynprm (the filter's
// tau; the muscle's tau_act, tau_deact)
OST_HD ostNum osti_actNext(int dyntype, const ostNum* dynprm, int actlimited,
                           const ostNum actrange[2], ostNum act, ostNum ctrl, ostNum h) {
  ostNum next = act;
  ostNum tau = dynprm[0];
  if (dyntype == OST_DYN_INTEGRATOR) {
    // act+ = act- + h act_dot; act_dot = ctrl does not depend on act: explicit = implicit
    next = act + h * ctrl;
  } else if (dyntype == OST_DYN_FILTER) {
    // act+ = act- + h (ctrl - act+) / tau, solved for act+; stable for any h / tau, and
    // act+ -> ctrl as tau -> 0 (the actuator without dynamics)
    ostNum t = tau;
    if (t < OST_ACT_MINTAU) {
      t = OST_ACT_MINTAU;
    }
    next = (t * act + h * ctrl) / (t + h);
  } else if (dyntype == OST_DYN_MUSCLE) {
    // act+ = act- + h act_dot(ctrl, act+), the time constant depending on both (eq. 8c)
    next = osti_muscleActNext(dynprm, act, ctrl, h);
  }
  return osti_actClamp(next, actlimited, actrange);
}


// the actuators' inputs for a step of size h from the controls ctrl (nu, as given) and the
// activations act (na, the start of the step): input[i] = ctrl clamped to ctrlrange for an
// actuator without dynamics, act+ for one with; act+ into act_next (na). With actuation
// disabled the activations are held (act+ = act-), as no act_dot is evaluated.
OST_HD void osti_actuation(const ostModel* m, const ostNum* ctrl, const ostNum* act, ostNum h,
                           ostNum* act_next, ostNum* input) {
  int clamp = !(m->disableflags & OST_DSBL_CLAMPCTRL);
  int off = !!(m->disableflags & OST_DSBL_ACTUATION);
  for (int i = 0; i < m->s.nu; i++) {
    ostNum c = osti_actClamp(ctrl[i], clamp && m->actuator_ctrllimited[i],
                             m->actuator_ctrlrange + 2 * i);
    int j = m->actuator_actadr[i];
    if (j < 0) {
      input[i] = c;
      continue;
    }
    act_next[j] = off ? act[j]
                      : osti_actNext(m->actuator_dyntype[i], m->actuator_dynprm + 2 * i,
                                     m->actuator_actlimited[i], m->actuator_actrange + 2 * i,
                                     act[j], c, h);
    input[i] = act_next[j];
  }
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_ACTIVATION_H_
