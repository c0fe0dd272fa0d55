;;; station_ops.clp — the station's energy scheduler on a session (issue 38 item 7): the
;;; session variant of station_power.clp, run by `robosim rules` beside the simulator of scene
;;; space_station_ops (`robosim up space_station_ops --with simulator,rules=station_ops,…`,
;;; `robosim study operations`; docs/rules.md).
;;;
;;; Facts come from the simulator's operations stage as the rules process mirrors it:
;;; (sim-power …) — the step, array power, battery, the eclipse ahead, the demand —,
;;; (sim-consumer …) per consumer with its priority and mode, (sim-attitude …). Decisions go
;;; back as simulator commands: {"cmd": "consumer", "name": N, "mode": M, "rule": R,
;;; "reason": TEXT}; the simulator records each with its step, and refuses to shed a vital one.
;;;
;;; The prediction (persistence forecast, seed §4.2 "predict the future energy production"):
;;; the arrays give what they give now until the next eclipse, nothing during it; the battery
;;; charges at charge-eff and gives at 1/discharge-eff. The lowest stored energy until the end
;;; of the next eclipse, with the plan's load, is compared with the reserve:
;;;   * below the reserve: hygiene switched off, then the experiment modules' air control
;;;     reduced — never the crew modules' (seed §4.2; vital consumers are never touched);
;;;   * above the reserve by the margin with the load restored: the experiment modules' air
;;;     control back to full first, then hygiene.
;;; One decision at a time, each predicted again with the plan as changed (the consumer's
;;; fact is modified at once; the simulator's next state confirms it).
;;; After every pass on a new step the rules acknowledge it: {"cmd": "ack", "who": "rules",
;;; "steps": N} — the operations study steps on only then, so a run does not depend on how
;;; fast this process is.
;;;
;;; Experiments (sim-experiment: each on its timetable, started by the simulator at its start
;;; time unless moved — {"cmd": "experiment", "name": N, "start_s": T, "rule", "reason"}):
;;;   * a microgravity-sensitive run whose planned time overlaps a docking window or the
;;;     desaturation window the momentum manager predicts (sim-window) is moved to the window's
;;;     end (a desaturation window's end plus ?*drift* for the prediction's drift); a running one
;;;     is stopped until then when the window opens within ?*soon* (seed §4.2 constraints 1-2);
;;;   * with hygiene deferred and the reserve still short, a run about to start is moved to the
;;;     next sunrise, and a running one stopped until then — before the experiment modules' air
;;;     is reduced.
;;; Faults (seed §4.3): eclss_guard.clp's rules, not repeated here — the shipped rule base
;;; `station_ops` (`rules=station_ops`, robosim_rules::embedded::SHIPPED) is eclss_guard.clp
;;; followed by this file, loaded as one; run from this file, give eclss_guard.clp its own rules
;;; process (`--with rules=eclss_guard,rules=FILE`). A plant alarm asks for a diagnosis; the
;;; diagnosed unit is isolated, then its spare brought on line (two transactions). The
;;; simulator follows the spare (its consumer's demand: standby, the spare starting, catching
;;; up); the scheduler notes each change of a fault's state with the demand and the prediction
;;; it now makes (ops-fault-reaction), and sheds by the rules above if the changed demand calls
;;; for it.

(defglobal ?*reserve* = 0.30   ; of the capacity, kept for the unforeseen
           ?*margin* = 0.10    ; above the reserve before a load is restored
           ?*drift* = 300.0    ; s after a predicted desaturation window (the prediction drifts)
           ?*soon* = 120.0)    ; s: a running sensitive run is stopped this close to a window

(deftemplate fault-noted (slot consumer) (slot state))

;;; The plan's load, kW: every consumer in its mode.
(deffunction ops-load ()
  (bind ?l 0.0)
  (do-for-all-facts ((?c sim-consumer)) TRUE
    (bind ?l (+ ?l (if (eq ?c:mode full) then ?c:full-kw
                    else (if (eq ?c:mode reduced) then ?c:reduced-kw else 0.0)))))
  (do-for-all-facts ((?e sim-experiment)) (eq ?e:state running)
    (bind ?l (+ ?l ?e:power-kw)))
  ?l)

;;; The next sunrise, s: the end of the eclipse under way or of the next one.
(deffunction ops-sunrise ()
  (bind ?s 0.0)
  (do-for-fact ((?p sim-power)) TRUE
    (bind ?s (if (eq ?p:eclipse yes) then (+ ?p:t ?p:eclipse-left-s)
              else (+ ?p:t ?p:to-eclipse-s ?p:eclipse-left-s))))
  ?s)

;;; The lowest stored energy (kWh) until the end of the next eclipse with the load ?l kW.
(deffunction ops-min-energy (?l)
  (bind ?min 0.0)
  (do-for-fact ((?p sim-power)) TRUE
    (bind ?e ?p:battery-kwh)
    (if (eq ?p:eclipse yes)
      then (bind ?min (- ?e (/ (* ?l (/ ?p:eclipse-left-s 3600.0)) ?p:discharge-eff)))
      else
        (bind ?net (- ?p:power-kw ?l))
        (bind ?h (/ ?p:to-eclipse-s 3600.0))
        (bind ?start (if (>= ?net 0.0)
                        then (min ?p:capacity-kwh (+ ?e (* ?net ?p:charge-eff ?h)))
                        else (+ ?e (/ (* ?net ?h) ?p:discharge-eff))))
        (bind ?end (- ?start (/ (* ?l (/ ?p:eclipse-left-s 3600.0)) ?p:discharge-eff)))
        (bind ?min (min ?e ?start ?end))))
  ?min)

(deffunction ops-reserve ()
  (bind ?r 0.0)
  (do-for-fact ((?p sim-power)) TRUE (bind ?r (* ?*reserve* ?p:capacity-kwh)))
  ?r)

(deffunction ops-margin ()
  (bind ?r 0.0)
  (do-for-fact ((?p sim-power)) TRUE (bind ?r (* ?*margin* ?p:capacity-kwh)))
  ?r)

(deffunction ops-kwh (?x) (format nil "%.1f" ?x))

;;; Sends a decision to the simulator; 0 when it took it.
(deffunction ops-decide (?rule ?name ?mode ?reason)
  (robosim sim (str-cat "{\"cmd\": \"consumer\", \"name\": \"" ?name "\", \"mode\": \"" ?mode
                        "\", \"rule\": \"" ?rule "\", \"reason\": \"" ?reason "\"}")))

;;; Moves (or stops) experiment ?name's run to ?start; 0 when the simulator took it.
(deffunction ops-experiment (?rule ?name ?start ?reason)
  (robosim sim (str-cat "{\"cmd\": \"experiment\", \"name\": \"" ?name "\", \"start_s\": "
                        ?start ", \"rule\": \"" ?rule "\", \"reason\": \"" ?reason "\"}")))

(deffunction ops-s (?x) (format nil "%.0f" ?x))

;;; ---------------------------------------------------------------- experiments and windows

(defrule ops-move-out-of-window
  (declare (salience 30))
  (sim-power (t ?now))
  ?e <- (sim-experiment (name ?x) (sensitive yes) (state ~running) (start-s ?s) (end-s ?end))
  (sim-window (kind ?k) (from-s ?a) (to-s ?b&:(> ?b ?now)))
  (test (and (< ?s ?b) (> ?end ?a)))
  =>
  (bind ?to (if (eq ?k desaturation) then (+ ?b ?*drift*) else ?b))
  (if (= 0 (ops-experiment ops-move-out-of-window ?x ?to
             (str-cat "planned " (ops-s ?s) "-" (ops-s ?end) " s overlaps the " ?k " window "
                      (ops-s ?a) "-" (ops-s ?b) " s: a microgravity run is moved after it")))
    then (modify ?e (start-s ?to) (end-s (+ ?to (- ?end ?s))))))

(defrule ops-stop-before-window
  (declare (salience 30))
  (sim-power (t ?now))
  ?e <- (sim-experiment (name ?x) (sensitive yes) (state running) (end-s ?end))
  (sim-window (kind ?k) (from-s ?a&:(<= ?a (+ ?now ?*soon*))) (to-s ?b&:(> ?b ?now)))
  (test (> ?end ?a))
  =>
  (bind ?to (if (eq ?k desaturation) then (+ ?b ?*drift*) else ?b))
  (if (= 0 (ops-experiment ops-stop-before-window ?x ?to
             (str-cat "the " ?k " window " (ops-s ?a) "-" (ops-s ?b) " s opens before the run ends ("
                      (ops-s ?end) " s): stopped, its time left kept")))
    then (modify ?e (state waiting) (start-s ?to) (end-s (+ ?to (- ?end ?now))))))

;;; ---------------------------------------------------------------- shedding

(defrule ops-shed-hygiene
  (declare (salience 20))
  ;; not on the state before the first step: the arrays have not turned to the sun yet
  (sim-power (steps ?n&:(> ?n 0)))
  ?c <- (sim-consumer (name hygiene) (mode full) (full-kw ?kw))
  (test (< (ops-min-energy (ops-load)) (ops-reserve)))
  =>
  (bind ?m (ops-min-energy (ops-load)))
  (if (= 0 (ops-decide ops-shed-hygiene hygiene off
             (str-cat "predicted minimum " (ops-kwh ?m) " kWh below the reserve "
                      (ops-kwh (ops-reserve)) " kWh: hygiene (" ?kw " kW, sheddable) deferred")))
    then (modify ?c (mode off))))

(defrule ops-defer-experiment
  (declare (salience 15))
  (sim-power (steps ?n&:(> ?n 0)) (t ?now))
  (sim-consumer (name hygiene) (mode off))
  ?e <- (sim-experiment (name ?x) (state ~running) (power-kw ?p)
                        (start-s ?s&:(<= ?s (+ ?now ?*soon*))) (end-s ?end))
  (test (> (ops-sunrise) (+ ?now ?*soon*)))
  (test (< (ops-min-energy (+ (ops-load) ?p)) (ops-reserve)))
  =>
  (bind ?to (ops-sunrise))
  (if (= 0 (ops-experiment ops-defer-experiment ?x ?to
             (str-cat "predicted minimum " (ops-kwh (ops-min-energy (+ (ops-load) ?p)))
                      " kWh with its " ?p " kW below the reserve " (ops-kwh (ops-reserve))
                      " kWh: the run waits for the next sunrise")))
    then (modify ?e (start-s ?to) (end-s (+ ?to (- ?end ?s))))))

(defrule ops-stop-experiment-for-energy
  (declare (salience 14))
  (sim-power (steps ?n&:(> ?n 0)) (t ?now))
  (sim-consumer (name hygiene) (mode off))
  ?e <- (sim-experiment (name ?x) (state running) (power-kw ?p) (end-s ?end))
  (not (sim-experiment (state running) (power-kw ?q&:(> ?q ?p))))
  (test (< (ops-min-energy (ops-load)) (ops-reserve)))
  =>
  (bind ?to (ops-sunrise))
  (if (= 0 (ops-experiment ops-stop-experiment-for-energy ?x ?to
             (str-cat "predicted minimum " (ops-kwh (ops-min-energy (ops-load)))
                      " kWh below the reserve " (ops-kwh (ops-reserve))
                      " kWh with hygiene off: the largest running experiment (" ?p
                      " kW) stopped until the next sunrise, its time left kept")))
    then (modify ?e (state waiting) (start-s ?to) (end-s (+ ?to (- ?end ?now))))))

(defrule ops-reduce-experiment-air
  (declare (salience 10))
  (sim-power (steps ?n&:(> ?n 0)))
  (sim-consumer (name hygiene) (mode off))
  (not (sim-experiment (state running)))
  ?c <- (sim-consumer (name air_experiment) (mode full) (full-kw ?f) (reduced-kw ?r))
  (test (< (ops-min-energy (ops-load)) (ops-reserve)))
  =>
  (bind ?m (ops-min-energy (ops-load)))
  (if (= 0 (ops-decide ops-reduce-experiment-air air_experiment reduced
             (str-cat "predicted minimum " (ops-kwh ?m) " kWh below the reserve "
                      (ops-kwh (ops-reserve)) " kWh with hygiene off: experiment modules' air "
                      "control reduced " ?f " -> " ?r " kW (the crew modules' is vital)")))
    then (modify ?c (mode reduced))))

;;; ---------------------------------------------------------------- restoring

(defrule ops-restore-experiment-air
  (declare (salience 5))
  (sim-power (steps ?n))
  ?c <- (sim-consumer (name air_experiment) (mode reduced) (full-kw ?f) (reduced-kw ?r))
  (test (> (ops-min-energy (+ (ops-load) (- ?f ?r))) (+ (ops-reserve) (ops-margin))))
  =>
  (bind ?m (ops-min-energy (+ (ops-load) (- ?f ?r))))
  (if (= 0 (ops-decide ops-restore-experiment-air air_experiment full
             (str-cat "predicted minimum " (ops-kwh ?m) " kWh at full load is above the reserve "
                      "and margin " (ops-kwh (+ (ops-reserve) (ops-margin)))
                      " kWh: experiment modules' air control back to full")))
    then (modify ?c (mode full))))

(defrule ops-restore-hygiene
  (declare (salience 4))
  (sim-power (steps ?n))
  (sim-consumer (name air_experiment) (mode full))
  ?c <- (sim-consumer (name hygiene) (mode off) (full-kw ?kw))
  (test (> (ops-min-energy (+ (ops-load) ?kw)) (+ (ops-reserve) (ops-margin))))
  =>
  (bind ?m (ops-min-energy (+ (ops-load) ?kw)))
  (if (= 0 (ops-decide ops-restore-hygiene hygiene full
             (str-cat "predicted minimum " (ops-kwh ?m) " kWh with hygiene is above the reserve "
                      "and margin " (ops-kwh (+ (ops-reserve) (ops-margin)))
                      " kWh: hygiene back on")))
    then (modify ?c (mode full))))

;;; ---------------------------------------------------------------- faults

(defrule ops-fault-reaction
  (declare (salience 25))
  (sim-power (steps ?n))
  (sim-fault (consumer ?c) (components $?u) (state ?st) (factor ?f))
  (sim-consumer (name ?c) (full-kw ?kw))
  (not (fault-noted (consumer ?c) (state ?st)))
  =>
  (assert (fault-noted (consumer ?c) (state ?st)))
  (robosim sim (str-cat "{\"cmd\": \"note\", \"consumer\": \"" ?c
                        "\", \"rule\": \"ops-fault-reaction\", \"reason\": \"" (implode$ ?u) " "
                        ?st ": " ?c " draws " ?kw " kW (x" ?f "); predicted minimum "
                        (ops-kwh (ops-min-energy (ops-load))) " kWh against the reserve "
                        (ops-kwh (ops-reserve)) " kWh\"}")))

;;; ---------------------------------------------------------------- acknowledging

(defrule ops-ack
  (declare (salience -100))
  (sim-power (steps ?n))
  =>
  (robosim sim (str-cat "{\"cmd\": \"ack\", \"who\": \"rules\", \"steps\": " ?n "}")))
