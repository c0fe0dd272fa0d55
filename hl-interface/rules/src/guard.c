/* The few things of CLIPS 6.30 that its API does not offer and that depend on the layout of
 * its structures, compiled against its own headers (/usr/include/clips) so the compiler, not
 * hand-copied offsets, knows the layout. Linked into the same archive as libclips.a (build.rs).
 *
 * 1. CLIPS's allocations: build.rs renames libclips's `malloc`/`free` to the two functions
 *    below, which count what CLIPS holds on this thread and refuse a request past the budget
 *    (CLIPS then calls its out-of-memory function: clips.rs turns that into a halt).
 * 2. A depth and stack guard on every deffunction and generic function call: the evaluate
 *    function of the PCALL/GCALL primitives is wrapped; the wrapper asks Rust (`enter`)
 *    before each call and halts the evaluation when it says no.
 * 3. The name of the rule firing now, and an argument of a user function read once (no
 *    second evaluation) with its evaluation error. */

#define _GNU_SOURCE
#include <malloc.h>
#include <pthread.h>
#include <stdlib.h>

#include "clips.h"

/* ---- 1. allocation budget ---------------------------------------------------------------- */

static _Thread_local size_t in_use;
/* 0: no budget. */
static _Thread_local size_t budget;
/* The budget in force: `budget`, or twice it once the budget was hit (the grace that lets
 * the evaluation unwind after the halt). */
static _Thread_local size_t allowed;

void *robosim_clips_malloc(size_t n) {
  if (allowed != 0 && (n > allowed || in_use > allowed - n)) {
    return NULL;
  }
  void *p = malloc(n);
  if (p != NULL) {
    in_use += malloc_usable_size(p);
  }
  return p;
}

void robosim_clips_free(void *p) {
  if (p != NULL) {
    size_t n = malloc_usable_size(p);
    in_use = in_use > n ? in_use - n : 0;
    free(p);
  }
}

void robosim_clips_set_budget(size_t bytes) {
  budget = bytes;
  allowed = bytes;
}

/* The budget was hit: allow twice it while the evaluation unwinds; 0 if that grace was
 * already given. */
int robosim_clips_grace(void) {
  if (budget == 0 || allowed != budget) {
    return 0;
  }
  allowed = budget > ((size_t)-1) / 2 ? (size_t)-1 : budget * 2;
  return 1;
}

/* After a pass: back to the budget. */
void robosim_clips_end_grace(void) { allowed = budget; }

size_t robosim_clips_in_use(void) { return in_use; }

/* ---- 2. call depth ----------------------------------------------------------------------- */

/* Rust's answer before a call: 0 to go on, else halt (it recorded why). `kind` is
 * "deffunction" or "generic function". */
typedef int (*robosim_enter_fn)(void *env, const char *kind, const char *name,
                                unsigned depth);

static robosim_enter_fn enter_hook;
static intBool (*original_pcall)(void *, void *, DATA_OBJECT *);
static intBool (*original_gcall)(void *, void *, DATA_OBJECT *);
static _Thread_local unsigned depth;

static void halt(void *env, DATA_OBJECT *result) {
  SetEvaluationError(env, TRUE);
  SetHaltExecution(env, TRUE);
  EnvSetHaltRules(env, TRUE);
  result->type = SYMBOL;
  result->value = EnvFalseSymbol(env);
}

static intBool guarded(intBool (*original)(void *, void *, DATA_OBJECT *), const char *kind,
                       const char *name, void *env, void *value, DATA_OBJECT *result) {
  if (original == NULL) {
    halt(env, result);
    return FALSE;
  }
  if (enter_hook != NULL && enter_hook(env, kind, name, depth + 1) != 0) {
    halt(env, result);
    return FALSE;
  }
  depth++;
  intBool r = original(env, value, result);
  depth--;
  return r;
}

static intBool guarded_pcall(void *env, void *value, DATA_OBJECT *result) {
  return guarded(original_pcall, "deffunction", EnvGetDeffunctionName(env, value), env, value,
                 result);
}

static intBool guarded_gcall(void *env, void *value, DATA_OBJECT *result) {
  return guarded(original_gcall, "generic function", EnvGetDefgenericName(env, value), env,
                 value, result);
}

/* Wraps the PCALL/GCALL primitives of `env` (its own entity records). 1 on success. */
int robosim_clips_guard_calls(void *env, robosim_enter_fn enter) {
  struct entityRecord *p = EvaluationData(env)->PrimitivesArray[PCALL];
  struct entityRecord *g = EvaluationData(env)->PrimitivesArray[GCALL];
  if (p == NULL || g == NULL || p->evaluateFunction == NULL || g->evaluateFunction == NULL) {
    return 0;
  }
  enter_hook = enter;
  if (p->evaluateFunction != guarded_pcall) {
    original_pcall = p->evaluateFunction;
    p->evaluateFunction = guarded_pcall;
  }
  if (g->evaluateFunction != guarded_gcall) {
    original_gcall = g->evaluateFunction;
    g->evaluateFunction = guarded_gcall;
  }
  return 1;
}

/* The bytes of stack left below the caller on this thread ((size_t)-1: unknown). */
static _Thread_local char *stack_low;

size_t robosim_clips_stack_left(void) {
  char here;
  if (stack_low == NULL) {
    pthread_attr_t a;
    void *addr;
    size_t size;
    if (pthread_getattr_np(pthread_self(), &a) != 0) {
      return (size_t)-1;
    }
    if (pthread_attr_getstack(&a, &addr, &size) != 0) {
      pthread_attr_destroy(&a);
      return (size_t)-1;
    }
    pthread_attr_destroy(&a);
    stack_low = (char *)addr;
  }
  return &here > stack_low ? (size_t)(&here - stack_low) : 0;
}

/* ---- 3. the rule firing now; an argument read once ----------------------------------------- */

const char *robosim_clips_executing_rule(void *env) {
  void *rule = EngineData(env)->ExecutingRule;
  return rule == NULL ? NULL : EnvGetDefruleName(env, rule);
}

/* Argument `i` of the user function being called, evaluated once. Returns its CLIPS type
 * (FLOAT, INTEGER, SYMBOL, STRING, INSTANCE_NAME: `num` or `text` set; another type: neither),
 * or -1 when its evaluation failed or the engine is halting (nothing is set then). */
int robosim_clips_arg(void *env, int i, double *num, const char **text) {
  DATA_OBJECT d;
  if (GetEvaluationError(env) || GetHaltExecution(env)) {
    return -1;
  }
  EnvRtnUnknown(env, i, &d);
  if (GetEvaluationError(env) || GetHaltExecution(env)) {
    return -1;
  }
  switch (GetType(d)) {
  case FLOAT:
    *num = DOToDouble(d);
    break;
  case INTEGER:
    *num = (double)DOToLong(d);
    break;
  case SYMBOL:
  case STRING:
  case INSTANCE_NAME:
    *text = DOToString(d);
    break;
  default:
    break;
  }
  return GetType(d);
}

/* Halts `env` (evaluation error, halt execution, halt rules). */
void robosim_clips_halt(void *env) {
  SetEvaluationError(env, TRUE);
  SetHaltExecution(env, TRUE);
  EnvSetHaltRules(env, TRUE);
}

/* After a pass: clears the halt so the environment can be used (or dropped) cleanly. */
void robosim_clips_clear_halt(void *env) {
  SetEvaluationError(env, FALSE);
  SetHaltExecution(env, FALSE);
  EnvSetHaltRules(env, FALSE);
}
