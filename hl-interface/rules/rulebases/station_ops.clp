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

(defglobal ?*reserve* = 0.30   ; of the capacity, kept for the unforeseen
           ?*margin* = 0.10)   ; above the reserve before a load is restored

;;; The plan's load, kW: every consumer in its mode.
(deffunction ops-load ()
  (bind ?l 0.0)
  (do-for-all-facts ((?c sim-consumer)) TRUE
    (bind ?l (+ ?l (if (eq ?c:mode full) then ?c:full-kw
                    else (if (eq ?c:mode reduced) then ?c:reduced-kw else 0.0)))))
  ?l)

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

(defrule ops-reduce-experiment-air
  (declare (salience 10))
  (sim-power (steps ?n&:(> ?n 0)))
  (sim-consumer (name hygiene) (mode off))
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

;;; ---------------------------------------------------------------- acknowledging

(defrule ops-ack
  (declare (salience -100))
  (sim-power (steps ?n))
  =>
  (robosim sim (str-cat "{\"cmd\": \"ack\", \"who\": \"rules\", \"steps\": " ?n "}")))
